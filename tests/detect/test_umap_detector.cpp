// UMapDetector on analytic depth images (tests/support/synthetic_depth.hpp): boxes in front of a
// back wall at known positions, empty images, walls, obstacles cut by the image edges, rotated
// poses, bad input and the zero-allocation rule.
//
// What is compared (map frame; the test pose maps camera z -> map x, camera x -> map -y,
// camera y -> map -z):
//  * lateral axes (map y, z = camera x, y): box centre within 0.1 m and size within 0.15 m of
//    the true box;
//  * the viewing axis (map x = camera depth): a depth camera sees only the near surface, so the
//    detector's box along the ray spans the visible surface, not the object (docs/design.md §4.4;
//    the tracker corrects this bias). We compare what the camera can measure: the near face within
//    0.1 m of the true front face, and the far side never more than 0.1 m beyond the true back
//    face. The centre/size along the ray are NOT compared against the full object here.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <random>
#include <vector>

#include "alloc_guard.hpp"
#include "dynamap/detect/umap_detector.hpp"
#include "synthetic_depth.hpp"

namespace dynamap {
namespace {

using test::SceneBox;
using test::SyntheticScene;

constexpr float kCentreTol = 0.10f;
constexpr float kSizeTol = 0.15f;

CameraIntrinsics camera(int width = 640, int height = 480) {
  CameraIntrinsics cam;  // 535.4 / 539.2 / 320.1 / 247.6, scale 0.001
  cam.width = width;
  cam.height = height;
  return cam;
}

SceneBox box_at(float x0, float x1, float y0, float y1, float z0, float z1) {
  return SceneBox{Eigen::Vector3f(x0, y0, z0), Eigen::Vector3f(x1, y1, z1)};
}

const Pose kPose = test::optical_to_map_pose(Eigen::Vector3f(0.5f, -1.f, 1.2f));

std::unique_ptr<UMapDetector> make_detector(const UMapDetectorConfig& cfg = {}) {
  auto d = std::make_unique<UMapDetector>();
  EXPECT_EQ(d->init(cfg), Status::kOk);
  return d;
}

// True if the detection matches the box under the criteria in the file comment.
// `visible` optionally clips the true lateral extent (obstacles cut by the image border).
bool matches(const Detection& d, const SceneBox& truth_cam, std::string* why = nullptr) {
  const Box3 t = test::box_to_map(truth_cam.min, truth_cam.max, kPose);
  const Box3& b = d.box;
  bool okay = true;
  for (int a : {1, 2}) {  // lateral axes
    const float dc = std::fabs(b.center()[a] - t.center()[a]);
    const float ds = std::fabs(b.size()[a] - t.size()[a]);
    if (dc > kCentreTol || ds > kSizeTol) okay = false;
  }
  const float front_err = std::fabs(b.min.x() - t.min.x());
  if (front_err > kCentreTol || b.max.x() > t.max.x() + kCentreTol) okay = false;
  if (why != nullptr) {
    char buf[400];
    std::snprintf(buf, sizeof(buf),
                  "det min(%.3f %.3f %.3f) max(%.3f %.3f %.3f) | truth min(%.3f %.3f %.3f) "
                  "max(%.3f %.3f %.3f)",
                  b.min.x(), b.min.y(), b.min.z(), b.max.x(), b.max.y(), b.max.z(), t.min.x(),
                  t.min.y(), t.min.z(), t.max.x(), t.max.y(), t.max.z());
    *why = buf;
  }
  return okay;
}

// Every true box is matched by exactly one detection and there are no other detections.
void expect_each_detected_once(const DetectionList& dets, const std::vector<SceneBox>& truth) {
  EXPECT_EQ(dets.size(), truth.size());
  for (const SceneBox& t : truth) {
    int hits = 0;
    std::string why_all;
    for (const Detection& d : dets) {
      std::string why;
      if (matches(d, t, &why)) ++hits;
      why_all += "\n  " + why;
    }
    EXPECT_EQ(hits, 1) << "truth box at z " << t.min.z() << why_all;
  }
}

DetectionList run(UMapDetector& det, const test::SyntheticImage& img, const CameraIntrinsics& cam,
                  const Pose& pose = kPose) {
  DetectionList out;
  EXPECT_EQ(det.detect(img.view(), cam, pose, out), Status::kOk);
  return out;
}

class OneBox : public ::testing::TestWithParam<float> {};

TEST_P(OneBox, DetectedOnceWithTrueLateralSizeAndFrontFace) {
  const float z = GetParam();
  const CameraIntrinsics cam = camera();
  for (float x_off : {-0.3f, 0.f, 0.25f}) {
    // 0.5 m wide, 0.7 m tall, 0.4 m deep; in view at every tested depth.
    SyntheticScene scene;
    scene.boxes = {box_at(x_off - 0.25f, x_off + 0.25f, -0.3f, 0.4f, z, z + 0.4f)};
    scene.wall_z = 6.5f;
    auto det = make_detector();
    const DetectionList out = run(*det, test::render_depth(scene, cam), cam);
    expect_each_detected_once(out, scene.boxes);
    if (out.size() == 1) {
      EXPECT_NEAR(out[0].near_depth, z, 0.01f);
      EXPECT_FALSE(out[0].refined);
      EXPECT_GT(out[0].image_box.u1, out[0].image_box.u0);
      EXPECT_GT(out[0].image_box.v1, out[0].image_box.v0);
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Depths, OneBox, ::testing::Values(1.f, 1.5f, 2.f, 3.f, 4.f, 5.f));

TEST(UMapDetector, TwoBoxes) {
  const CameraIntrinsics cam = camera();
  SyntheticScene scene;
  scene.boxes = {box_at(-0.9f, -0.4f, -0.4f, 0.5f, 2.f, 2.5f),
                 box_at(0.5f, 1.1f, -0.6f, 0.3f, 3.5f, 3.8f)};
  scene.wall_z = 6.f;
  auto det = make_detector();
  expect_each_detected_once(run(*det, test::render_depth(scene, cam), cam), scene.boxes);
}

std::vector<SceneBox> five_boxes() {
  return {
      box_at(-0.55f, -0.30f, -0.1f, 0.3f, 1.f, 1.4f), box_at(-0.40f, 0.00f, -0.3f, 0.3f, 2.f, 2.4f),
      box_at(0.10f, 0.50f, -0.5f, 0.4f, 3.f, 3.4f), box_at(0.80f, 1.20f, -0.4f, 0.6f, 4.f, 4.4f),
      box_at(1.80f, 2.20f, -0.6f, 0.6f, 5.f, 5.4f)};
}

TEST(UMapDetector, FiveBoxesNearestFirst) {
  const CameraIntrinsics cam = camera();
  SyntheticScene scene;
  scene.boxes = five_boxes();
  scene.wall_z = 6.5f;
  auto det = make_detector();
  const DetectionList out = run(*det, test::render_depth(scene, cam), cam);
  expect_each_detected_once(out, scene.boxes);
  for (std::size_t i = 1; i < out.size(); ++i) {
    EXPECT_LE(out[i - 1].near_depth, out[i].near_depth);
  }
  EXPECT_EQ(det->last_stats().detections, out.size());
  EXPECT_EQ(det->last_stats().detections_dropped, 0u);
  EXPECT_GE(det->last_stats().rejected_size, 1u);  // the back wall
}

TEST(UMapDetector, FiveBoxesWithSmoothingAndScalarKernelAgree) {
  const CameraIntrinsics cam = camera();
  SyntheticScene scene;
  scene.boxes = five_boxes();
  scene.wall_z = 6.5f;
  const auto img = test::render_depth(scene, cam);
  UMapDetectorConfig smooth;
  smooth.smoothing_radius = 1;
  auto det_s = make_detector(smooth);
  expect_each_detected_once(run(*det_s, img, cam), scene.boxes);

  UMapDetectorConfig scalar;
  scalar.use_fast_histogram = false;
  auto det_a = make_detector(scalar);
  auto det_b = make_detector();
  const DetectionList a = run(*det_a, img, cam);
  const DetectionList b = run(*det_b, img, cam);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].box.min, b[i].box.min);
    EXPECT_EQ(a[i].box.max, b[i].box.max);
  }
}

TEST(UMapDetector, FiveBoxesWithDepthNoiseAndDropouts) {
  // Stereo-like noise: sigma = 0.003 * z^2 (7.5 cm at 5 m) and 3 % missing pixels; same
  // tolerances as the clean scenes, with and without smoothing.
  const CameraIntrinsics cam = camera();
  SyntheticScene scene;
  scene.boxes = five_boxes();
  scene.wall_z = 6.5f;
  auto img = test::render_depth(scene, cam);
  std::mt19937 rng(2024);
  std::normal_distribution<float> gauss(0.f, 1.f);
  std::uniform_real_distribution<float> uniform(0.f, 1.f);
  for (std::uint16_t& p : img.pixels) {
    if (p == 0) continue;
    if (uniform(rng) < 0.03f) {
      p = 0;
      continue;
    }
    const float z = static_cast<float>(p) * cam.depth_scale;
    p = static_cast<std::uint16_t>(
        std::lround((z + 0.003f * z * z * gauss(rng)) / cam.depth_scale));
  }
  for (int radius : {0, 1}) {
    UMapDetectorConfig cfg;
    cfg.smoothing_radius = radius;
    auto det = make_detector(cfg);
    expect_each_detected_once(run(*det, img, cam), scene.boxes);
  }
}

TEST(UMapDetector, BoxStandingOnFloor) {
  // Camera 1.0 m above a floor; the floor alone is never an obstacle, the box on it is found
  // with its true height.
  const CameraIntrinsics cam = camera();
  SyntheticScene floor_only;
  floor_only.floor_y = 1.0f;
  floor_only.wall_z = 7.f;
  auto det = make_detector();
  EXPECT_EQ(run(*det, test::render_depth(floor_only, cam), cam).size(), 0u);
  for (float z : {2.5f, 3.5f, 4.5f}) {
    SyntheticScene scene = floor_only;
    scene.boxes = {box_at(-0.3f, 0.3f, -0.2f, 1.0f, z, z + 0.5f)};
    expect_each_detected_once(run(*det, test::render_depth(scene, cam), cam), scene.boxes);
  }
}

TEST(UMapDetector, NothingOnEmptyImageOrFlatWall) {
  const CameraIntrinsics cam = camera();
  auto det = make_detector();
  EXPECT_EQ(run(*det, test::render_depth(SyntheticScene{}, cam), cam).size(), 0u);
  for (float wall : {0.6f, 1.f, 2.f, 3.f, 5.f, 7.5f, 9.f}) {
    SyntheticScene scene;
    scene.wall_z = wall;
    EXPECT_EQ(run(*det, test::render_depth(scene, cam), cam).size(), 0u) << "wall at " << wall;
  }
}

TEST(UMapDetector, ObstaclesCutByImageEdges) {
  // Boxes extending past the left, right, top and bottom borders (odd image width too). The
  // truth is the visible part: its lateral extent clipped to the view frustum at its front face.
  for (int width : {640, 639, 333}) {
    CameraIntrinsics cam = camera(width, 480);
    cam.cx = 0.5f * static_cast<float>(width) - 0.3f;
    auto det = make_detector();
    const float z = 2.f;
    const float x_left = (-0.5f - cam.cx) * z / cam.fx;  // frustum at depth z (pixel edges)
    const float x_right = (static_cast<float>(width) - 0.5f - cam.cx) * z / cam.fx;
    const float y_top = (-0.5f - cam.cy) * z / cam.fy;
    const float y_bottom = (479.5f - cam.cy) * z / cam.fy;
    struct Case {
      SceneBox box;
      SceneBox visible;
    };
    const Case cases[] = {
        {box_at(x_left - 0.5f, x_left + 0.4f, -0.3f, 0.3f, z, z + 0.3f),
         box_at(x_left, x_left + 0.4f, -0.3f, 0.3f, z, z + 0.3f)},
        {box_at(x_right - 0.4f, x_right + 0.5f, -0.3f, 0.3f, z, z + 0.3f),
         box_at(x_right - 0.4f, x_right, -0.3f, 0.3f, z, z + 0.3f)},
        {box_at(-0.2f, 0.2f, y_top - 1.f, y_bottom + 1.f, z, z + 0.3f),  // taller than the view
         box_at(-0.2f, 0.2f, y_top, y_bottom, z, z + 0.3f)},
        {box_at(x_left - 0.5f, x_left + 0.3f, y_top - 1.f, y_top + 0.6f, z, z + 0.3f),  // corner
         box_at(x_left, x_left + 0.3f, y_top, y_top + 0.6f, z, z + 0.3f)},
    };
    for (const Case& c : cases) {
      SyntheticScene scene;
      scene.boxes = {c.box};
      scene.wall_z = 6.f;
      const DetectionList out = run(*det, test::render_depth(scene, cam, /*pad=*/0), cam);
      ASSERT_EQ(out.size(), 1u) << "width " << width;
      std::string why;
      EXPECT_TRUE(matches(out[0], c.visible, &why)) << why;
      const ImageBox& ib = out[0].image_box;
      EXPECT_GE(ib.u0, 0);
      EXPECT_LE(ib.u1, width - 1);
      EXPECT_GE(ib.v0, 0);
      EXPECT_LE(ib.v1, 479);
      EXPECT_TRUE(ib.u0 == 0 || ib.u1 == width - 1 || ib.v0 == 0 || ib.v1 == 479);
    }
  }
}

// An upright 0.5 x 0.5 x 1.8 m box (map frame) 3 m ahead of a camera 1.3 m high pitched 10
// degrees down, in front of a wall at 8 m. The map box comes from mean surface points: along
// the ray it spans the visible front face only (thinner than a voxel), at the true distance;
// laterally and vertically it matches the box (the bounds of the camera box's 8 transformed
// corners would stretch it along the ray by about 1.8 m * sin(10 deg) = 0.31 m).
TEST(UMapDetector, PitchedCameraKeepsUprightObjectsDepthExtent) {
  const CameraIntrinsics cam = camera();
  const float pitch = 10.f * 3.14159265f / 180.f;
  Pose pose = test::optical_to_map_pose(Eigen::Vector3f(0.f, 0.f, 1.3f));
  pose.rotation = (Eigen::AngleAxisf(pitch, Eigen::Vector3f::UnitY()) * pose.rotation).normalized();
  const Eigen::Vector3f bmin(3.f, -0.25f, 0.f), bmax(3.5f, 0.25f, 1.8f);
  const float wall_x = 8.f;
  test::SyntheticImage img;
  img.width = cam.width;
  img.height = cam.height;
  img.stride = cam.width;
  img.pixels.assign(static_cast<std::size_t>(cam.width * cam.height), 0);
  const Eigen::Matrix3f R = pose.rotation.toRotationMatrix();
  for (int v = 0; v < cam.height; ++v) {
    for (int u = 0; u < cam.width; ++u) {
      // Camera ray with z = 1, so the ray parameter is the depth.
      const Eigen::Vector3f d_cam((static_cast<float>(u) - cam.cx) / cam.fx,
                                  (static_cast<float>(v) - cam.cy) / cam.fy, 1.f);
      const Eigen::Vector3f d = R * d_cam;
      const Eigen::Vector3f& o = pose.translation;
      float t = d.x() > 0.f ? (wall_x - o.x()) / d.x() : 1e30f;
      float t0 = 0.f, t1 = 1e30f;  // slab test against the upright box
      for (int a = 0; a < 3; ++a) {
        if (std::fabs(d[a]) < 1e-9f) {
          if (o[a] < bmin[a] || o[a] > bmax[a]) t0 = 1e30f;
          continue;
        }
        float ta = (bmin[a] - o[a]) / d[a], tb = (bmax[a] - o[a]) / d[a];
        if (ta > tb) std::swap(ta, tb);
        t0 = std::max(t0, ta);
        t1 = std::min(t1, tb);
      }
      if (t0 <= t1 && t0 < t) t = t0;
      if (t >= 1e29f || o.z() + t * d.z() < 0.f) continue;  // beyond the wall or below z = 0
      img.pixels[static_cast<std::size_t>(v * cam.width + u)] =
          static_cast<std::uint16_t>(std::round(t / cam.depth_scale));
    }
  }
  auto det = make_detector();
  const DetectionList out = run(*det, img, cam, pose);
  ASSERT_EQ(out.size(), 1u);
  const Box3& b = out[0].box;
  EXPECT_NEAR(b.min.x(), bmin.x(), 0.02f);
  EXPECT_LT(b.size().x(), 0.1f);
  EXPECT_NEAR(b.min.y(), bmin.y(), 0.03f);
  EXPECT_NEAR(b.max.y(), bmax.y(), 0.03f);
  EXPECT_NEAR(b.max.z(), bmax.z(), 0.05f);
  EXPECT_LT(b.min.z(), 0.1f);
}

TEST(UMapDetector, DropsAndCountsDetectionsOverCapacity) {
  const CameraIntrinsics cam = camera();
  SyntheticScene scene;
  scene.boxes = five_boxes();
  scene.wall_z = 6.5f;
  UMapDetectorConfig cfg;
  cfg.max_detections = 3;
  auto det = make_detector(cfg);
  const DetectionList out = run(*det, test::render_depth(scene, cam), cam);
  ASSERT_EQ(out.size(), 3u);
  EXPECT_EQ(det->last_stats().detections_dropped, 2u);
  for (std::size_t i = 0; i < 3; ++i) {  // the nearest three are kept
    std::string why;
    EXPECT_TRUE(matches(out[i], scene.boxes[i], &why)) << why;
  }
  cfg.max_detections = 5;
  cfg.max_candidates = 2;  // bounded height searches
  ASSERT_EQ(det->init(cfg), Status::kOk);
  EXPECT_EQ(run(*det, test::render_depth(scene, cam), cam).size(), 2u);
  EXPECT_GE(det->last_stats().candidates_dropped, 3u);
}

TEST(UMapDetector, BadInputReturnsStatusAndChangesNothing) {
  const CameraIntrinsics cam = camera();
  SyntheticScene scene;
  scene.boxes = five_boxes();
  scene.wall_z = 6.5f;
  const auto img = test::render_depth(scene, cam);

  auto fresh = std::make_unique<UMapDetector>();
  DetectionList out;
  EXPECT_EQ(fresh->detect(img.view(), cam, kPose, out), Status::kNotInitialized);

  auto det = make_detector();
  out = run(*det, img, cam);
  ASSERT_EQ(out.size(), 5u);
  const DetectionList before = out;
  const UMapDetectorStats stats_before = det->last_stats();

  DepthView null_view = img.view();
  null_view.data = nullptr;
  EXPECT_EQ(det->detect(null_view, cam, kPose, out), Status::kNullData);
  CameraIntrinsics small = cam;
  small.width = 320;
  EXPECT_EQ(det->detect(img.view(), small, kPose, out), Status::kWrongSize);
  DepthView short_stride = img.view();
  short_stride.stride_bytes = 100;
  EXPECT_EQ(det->detect(short_stride, cam, kPose, out), Status::kWrongSize);
  Pose nan_pose = kPose;
  nan_pose.translation.x() = NAN;
  EXPECT_EQ(det->detect(img.view(), cam, nan_pose, out), Status::kNonFinite);
  Pose scaled = kPose;
  scaled.rotation.coeffs() *= 1.1f;
  EXPECT_EQ(det->detect(img.view(), cam, scaled, out), Status::kNonUnitQuaternion);
  CameraIntrinsics bad_fx = cam;
  bad_fx.fx = 0.f;
  EXPECT_EQ(det->detect(img.view(), bad_fx, kPose, out), Status::kInvalidArgument);
  CameraIntrinsics bad_scale = cam;
  bad_scale.depth_scale = 0.01f;  // d_max 8 m = 800 units < nothing wrong; 1e-5 overflows uint16
  bad_scale.depth_scale = 1e-5f;
  EXPECT_EQ(det->detect(img.view(), bad_scale, kPose, out), Status::kInvalidArgument);
  std::vector<std::uint16_t> big(700 * 480, 1000);
  CameraIntrinsics big_cam = cam;
  big_cam.width = 700;
  EXPECT_EQ(det->detect(DepthView{big.data(), 700, 480, 1400}, big_cam, kPose, out),
            Status::kWrongSize);

  ASSERT_EQ(out.size(), before.size());
  for (std::size_t i = 0; i < out.size(); ++i) {
    EXPECT_EQ(out[i].box.min, before[i].box.min);
    EXPECT_EQ(out[i].box.max, before[i].box.max);
  }
  EXPECT_EQ(det->last_stats().detections, stats_before.detections);
  EXPECT_EQ(det->last_stats().groups, stats_before.groups);
}

TEST(UMapDetector, BadConfigIsRefusedAndOldConfigKept) {
  auto det = make_detector();
  UMapDetectorConfig bad;
  bad.bins = kMaxUMapBins + 1;
  EXPECT_EQ(det->init(bad), Status::kInvalidArgument);
  bad = {};
  bad.d_max = bad.d_min;
  EXPECT_EQ(det->init(bad), Status::kInvalidArgument);
  bad = {};
  bad.smoothing_radius = kMaxUMapSmoothingRadius + 1;
  EXPECT_EQ(det->init(bad), Status::kInvalidArgument);
  bad = {};
  bad.band_factor = 0.5f;
  EXPECT_EQ(det->init(bad), Status::kInvalidArgument);
  bad = {};
  bad.max_detections = kMaxDetections + 1;
  EXPECT_EQ(det->init(bad), Status::kInvalidArgument);
  bad = {};
  bad.row_fill_fraction = NAN;
  EXPECT_EQ(det->init(bad), Status::kInvalidArgument);
  EXPECT_EQ(det->config().bins, UMapDetectorConfig{}.bins);
  // Still works with the old configuration.
  const CameraIntrinsics cam = camera();
  SyntheticScene scene;
  scene.boxes = five_boxes();
  scene.wall_z = 6.5f;
  EXPECT_EQ(run(*det, test::render_depth(scene, cam), cam).size(), 5u);
}

// The fast height search and box sums (use_fast_measure, the default) against the per-pixel
// reference loops: same detections bit for bit and same counters.
void expect_same_as_reference(const test::SyntheticImage& img, const CameraIntrinsics& cam,
                              const Pose& pose, UMapDetectorConfig cfg, std::size_t* found) {
  cfg.use_fast_measure = true;
  auto fast = make_detector(cfg);
  cfg.use_fast_measure = false;
  auto ref = make_detector(cfg);
  DetectionList a, b;
  ASSERT_EQ(fast->detect(img.view(), cam, pose, a), Status::kOk);
  ASSERT_EQ(ref->detect(img.view(), cam, pose, b), Status::kOk);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].box.min, b[i].box.min) << i;
    EXPECT_EQ(a[i].box.max, b[i].box.max) << i;
    EXPECT_EQ(a[i].raw_box.min, b[i].raw_box.min) << i;
    EXPECT_EQ(a[i].raw_box.max, b[i].raw_box.max) << i;
    EXPECT_EQ(a[i].image_box.u0, b[i].image_box.u0) << i;
    EXPECT_EQ(a[i].image_box.v0, b[i].image_box.v0) << i;
    EXPECT_EQ(a[i].image_box.u1, b[i].image_box.u1) << i;
    EXPECT_EQ(a[i].image_box.v1, b[i].image_box.v1) << i;
    EXPECT_EQ(a[i].near_depth, b[i].near_depth) << i;
  }
  const UMapDetectorStats& sa = fast->last_stats();
  const UMapDetectorStats& sb = ref->last_stats();
  EXPECT_EQ(sa.segments, sb.segments);
  EXPECT_EQ(sa.groups, sb.groups);
  EXPECT_EQ(sa.rejected_area, sb.rejected_area);
  EXPECT_EQ(sa.rejected_size, sb.rejected_size);
  EXPECT_EQ(sa.rejected_height, sb.rejected_height);
  EXPECT_EQ(sa.candidates_dropped, sb.candidates_dropped);
  EXPECT_EQ(sa.detections_dropped, sb.detections_dropped);
  *found += a.size();
}

TEST(UMapDetector, FastMeasureMatchesReferenceOnRandomFrames) {
  // Random boxes, walls, floors, noise and dropouts, odd widths (chunk tails), pitched and
  // rolled poses, with the default limits and with limits wide enough that every group is
  // measured and output (walls and floors included: long, wide runs of pixels).
  std::mt19937 rng(17);
  std::uniform_real_distribution<float> uni(0.f, 1.f);
  std::normal_distribution<float> gauss(0.f, 1.f);
  std::size_t found_default = 0, found_wide = 0;
  for (int frame = 0; frame < 24; ++frame) {
    const int widths[] = {640, 637, 333, 97};
    CameraIntrinsics cam = camera(widths[frame % 4], frame % 3 == 0 ? 480 : 211);
    cam.cx = 0.5f * static_cast<float>(cam.width);
    cam.cy = 0.5f * static_cast<float>(cam.height);
    SyntheticScene scene;
    const int n = 1 + static_cast<int>(rng() % 6);
    for (int k = 0; k < n; ++k) {
      const float z = 0.5f + 6.f * uni(rng), x = -3.f + 6.f * uni(rng);
      const float w = 0.1f + 1.2f * uni(rng), h = 0.3f + 2.f * uni(rng);
      scene.boxes.push_back(box_at(x, x + w, 1.f - h, 1.f, z, z + 0.2f + uni(rng)));
    }
    scene.wall_z = frame % 5 == 0 ? 0.f : 3.f + 6.f * uni(rng);
    scene.floor_y = frame % 2 == 0 ? 1.f : 0.f;
    auto img = test::render_depth(scene, cam);
    for (std::uint16_t& p : img.pixels) {
      if (p == 0) continue;
      if (uni(rng) < 0.05f) {
        p = 0;
        continue;
      }
      const float z = static_cast<float>(p) * cam.depth_scale;
      p = static_cast<std::uint16_t>(
          std::lround(std::max(0.f, z + 0.003f * z * z * gauss(rng)) / cam.depth_scale));
    }
    const Eigen::Quaternionf tilt(
        Eigen::AngleAxisf(0.4f * (uni(rng) - 0.5f), Eigen::Vector3f::UnitY()) *
        Eigen::AngleAxisf(0.2f * (uni(rng) - 0.5f), Eigen::Vector3f::UnitX()));
    Pose pose = kPose;
    pose.rotation = (tilt * kPose.rotation).normalized();
    UMapDetectorConfig cfg;
    cfg.smoothing_radius = static_cast<int>(rng() % 2);
    expect_same_as_reference(img, cam, pose, cfg, &found_default);
    UMapDetectorConfig wide = cfg;
    wide.band_factor = 1.f + 3.f * uni(rng);
    wide.max_width_fraction = 1.f;
    wide.max_width = wide.max_height = wide.max_depth_extent = 1000.f;
    wide.min_run_rows = 1;
    wide.row_fill_fraction = 0.f;
    expect_same_as_reference(img, cam, pose, wide, &found_wide);
  }
  EXPECT_GT(found_default, 24u);
  EXPECT_GT(found_wide, found_default);
}

TEST(UMapDetector, FastMeasureMatchesReferenceAtLargeRawDepths) {
  // 0.1 mm per unit: a wall at 6.5 m is raw 65000 over all 480 rows, so the 32-bit partial
  // column sums of the fast path are near their limit (flushed every 128 rows) and the band
  // reaches raw 65535.
  CameraIntrinsics cam = camera();
  cam.depth_scale = 0.0001f;
  UMapDetectorConfig cfg;
  cfg.d_min = 0.5f;
  cfg.d_max = 6.5535f;
  cfg.band_factor = 4.f;
  cfg.max_width_fraction = 1.f;
  cfg.max_width = cfg.max_height = cfg.max_depth_extent = 1000.f;
  std::size_t found = 0;
  for (float wall : {6.5f, 6.5535f, 3.f}) {
    SyntheticScene scene;
    scene.boxes = {box_at(-0.4f, 0.4f, -2.f, 1.f, wall - 0.9f, wall - 0.5f)};
    scene.wall_z = wall;
    expect_same_as_reference(test::render_depth(scene, cam), cam, kPose, cfg, &found);
  }
  EXPECT_GE(found, 3u);
}

TEST(UMapDetector, ZeroAllocationsPerFrame) {
  const CameraIntrinsics cam = camera();
  SyntheticScene scene;
  scene.boxes = five_boxes();
  scene.wall_z = 6.5f;
  const auto img = test::render_depth(scene, cam);
  auto det = make_detector();
  auto out = std::make_unique<DetectionList>();
  test::AllocationGuard guard;
  for (int i = 0; i < 5; ++i) ASSERT_EQ(det->detect(img.view(), cam, kPose, *out), Status::kOk);
  EXPECT_EQ(guard.allocations(), 0u);
  EXPECT_EQ(out->size(), 5u);
}

}  // namespace
}  // namespace dynamap
