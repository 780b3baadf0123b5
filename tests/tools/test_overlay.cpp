// Tests of dynamap-overlay's library (tools/overlay): box projection, the depth colour map,
// detections.csv, the missed / false-dynamic classification and a whole run on a small
// simulated sequence.
#include <gtest/gtest.h>

#include <stdlib.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>

#include "common/obstacles.hpp"
#include "common/sequence.hpp"
#include "common/text_io.hpp"
#include "overlay/overlay.hpp"
#include "sim/scene.hpp"
#include "sim/writer.hpp"

namespace fs = std::filesystem;
using namespace dynamap::tools;
using namespace dynamap::tools::overlay;

namespace {

// One temporary directory per test process, removed at exit (also when a test fails).
class ProcessTempDir : public ::testing::Environment {
 public:
  static std::string path() { return path_; }
  void SetUp() override {
    char tmpl[] = "/tmp/dynamap_test_overlay_XXXXXX";
    const char* p = ::mkdtemp(tmpl);
    ASSERT_NE(p, nullptr);
    path_ = p;
  }
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }

 private:
  static inline std::string path_;
};
const auto* const kTempEnv = ::testing::AddGlobalTestEnvironment(new ProcessTempDir);

void write_file(const std::string& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
}

// Width and height from a PNG's IHDR chunk (bytes 16..23, big-endian); {0, 0} when not a PNG.
std::pair<int, int> png_size(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  unsigned char b[24] = {};
  in.read(reinterpret_cast<char*>(b), sizeof(b));
  if (!in || b[1] != 'P' || b[2] != 'N' || b[3] != 'G') return {0, 0};
  auto be32 = [&](int i) { return (b[i] << 24) | (b[i + 1] << 16) | (b[i + 2] << 8) | b[i + 3]; };
  return {be32(16), be32(20)};
}

CameraModel test_camera() {
  CameraModel c;
  c.fx = c.fy = 500.0;
  c.cx = 320.0;
  c.cy = 240.0;
  c.width = 640;
  c.height = 480;
  return c;
}

// A z-up world camera at (0, 0, 1) looking along world +x: optical x = world -y, y = world -z,
// z = world +x.
PoseD z_up_camera_at_1m() {
  PoseD pose;
  pose.translation = {0, 0, 1};
  Eigen::Matrix3d r_wc;
  r_wc.col(0) = Eigen::Vector3d(0, -1, 0);
  r_wc.col(1) = Eigen::Vector3d(0, 0, -1);
  r_wc.col(2) = Eigen::Vector3d(1, 0, 0);
  pose.rotation = Eigen::Quaterniond(r_wc);
  return pose;
}

}  // namespace

// ------------------------------------------------------------------------- projection ------

TEST(OverlayProjection, BoxInFrontProjectsToTheHandComputedRectangle) {
  const CameraModel cam = test_camera();
  // Camera at the origin looking along its optical z: x in [-0.5, 0.5], y in [-1, 1], z in
  // [3, 5]. The widest extent is at the near face z = 3: u = 320 +- 500 * 0.5 / 3,
  // v = 240 +- 500 * 1 / 3.
  PixelRect r;
  ASSERT_TRUE(project_box(cam, PoseD{}, {0, 0, 4}, {1, 2, 2}, &r));
  EXPECT_NEAR(r.u0, 320.0 - 250.0 / 3.0, 1e-9);
  EXPECT_NEAR(r.u1, 320.0 + 250.0 / 3.0, 1e-9);
  EXPECT_NEAR(r.v0, 240.0 - 500.0 / 3.0, 1e-9);
  EXPECT_NEAR(r.v1, 240.0 + 500.0 / 3.0, 1e-9);

  // The same box seen by a z-up world camera at (0, 0, 1) looking along world +x: optical
  // x = world -y, y = world -z, z = world +x. The box, 3..5 m ahead, 1 m wide, from the floor to
  // 2 m, gives the same rectangle.
  const PoseD pose = z_up_camera_at_1m();
  PixelRect w;
  ASSERT_TRUE(project_box(cam, pose, {4, 0, 1}, {2, 1, 2}, &w));
  EXPECT_NEAR(w.u0, r.u0, 1e-9);
  EXPECT_NEAR(w.u1, r.u1, 1e-9);
  EXPECT_NEAR(w.v0, r.v0, 1e-9);
  EXPECT_NEAR(w.v1, r.v1, 1e-9);
  // 1 m to the world's left (+y): optical x in [-1.5, -0.5]. The left edge is widest at the
  // near face (u = 320 - 500 * 1.5 / 3 = 70), the right edge, on the axis side, at the far face
  // (u = 320 - 500 * 0.5 / 5 = 270).
  ASSERT_TRUE(project_box(cam, pose, {4, 1, 1}, {2, 1, 2}, &w));
  EXPECT_NEAR(w.u0, 70.0, 1e-9);
  EXPECT_NEAR(w.u1, 270.0, 1e-9);
}

TEST(OverlayProjection, MotionArrowIsTheHorizontalVelocityOverItsTime) {
  const CameraModel cam = test_camera();
  Eigen::Vector2d from, to;
  // Identity pose (world = optical frame): 1 m/s along x for 0.5 s, 4 m ahead: u = 320 + 500 *
  // 0.5 / 4. The world z part of a velocity is not drawn (here it is the optical axis).
  ASSERT_TRUE(project_motion(cam, PoseD{}, {0, 0, 4}, {1, 0, 3}, 0.5, &from, &to));
  EXPECT_NEAR(from.x(), 320.0, 1e-9);
  EXPECT_NEAR(from.y(), 240.0, 1e-9);
  EXPECT_NEAR(to.x(), 320.0 + 62.5, 1e-9);
  EXPECT_NEAR(to.y(), 240.0, 1e-9);
  // The z-up camera of the test above: walking to the world's left (+y) is towards image left.
  const PoseD pose = z_up_camera_at_1m();
  ASSERT_TRUE(project_motion(cam, pose, {4, 0, 1}, {0, 1, 0}, 0.5, &from, &to));
  EXPECT_NEAR(from.x(), 320.0, 1e-9);
  EXPECT_NEAR(to.x(), 320.0 - 62.5, 1e-9);
  EXPECT_NEAR(to.y(), 240.0, 1e-9);
  // Either end behind the camera: nothing to draw.
  EXPECT_FALSE(project_motion(cam, PoseD{}, {0, 0, -1}, {1, 0, 0}, 0.5, &from, &to));
  EXPECT_FALSE(project_motion(cam, pose, {0.3, 0, 1}, {-1, 0, 0}, 0.5, &from, &to));
}

TEST(OverlayProjection, BoxBehindOrBesideTheCameraIsNotDrawn) {
  const CameraModel cam = test_camera();
  PixelRect r;
  EXPECT_FALSE(project_box(cam, PoseD{}, {0, 0, -4}, {1, 2, 2}, &r));     // behind
  EXPECT_FALSE(project_box(cam, PoseD{}, {0, 0, 0.0}, {1, 1, 0.1}, &r));  // before z = 0.1
  EXPECT_FALSE(project_box(cam, PoseD{}, {20, 0, 4}, {1, 1, 1}, &r));     // far right of the image
  // Straddling the camera plane: only the part beyond z = 0.1 counts, so the rectangle is
  // finite (x = +-0.5 at z = 0.1 is u = 320 +- 2500) and covers the image.
  ASSERT_TRUE(project_box(cam, PoseD{}, {0, 0, 0.5}, {1, 1, 2}, &r));
  EXPECT_NEAR(r.u0, 320.0 - 2500.0, 1e-6);
  EXPECT_NEAR(r.u1, 320.0 + 2500.0, 1e-6);
}

// ---------------------------------------------------------------------------- colours ------

TEST(OverlayColourMap, NearIsWarmFarIsCoolZeroIsNoData) {
  for (double near : {0.3, 0.5, 0.8}) {
    const Rgb8 c = depth_colour(near);
    EXPECT_GT(c.r, c.b + 100) << near << " m";
  }
  for (double far : {5.0, 8.0, 20.0}) {
    const Rgb8 c = depth_colour(far);
    EXPECT_GT(c.b, c.r + 50) << far << " m";
  }
  const Rgb8 none = depth_colour(0.0);
  EXPECT_EQ(none.r, kNoDepthColour.r);
  EXPECT_EQ(none.g, kNoDepthColour.g);
  EXPECT_EQ(none.b, kNoDepthColour.b);
  // Fixed scale: a distance always has the same colour (no per-frame normalisation).
  EXPECT_EQ(depth_colour(2.0).g, depth_colour(2.0).g);
  // Below the near end and beyond the far end: clamped, not wrapped.
  EXPECT_EQ(depth_colour(0.1).r, depth_colour(0.3).r);
  EXPECT_EQ(depth_colour(50.0).b, depth_colour(8.0).b);
}

// --------------------------------------------------------------------- detections.csv ------

TEST(OverlayDetections, ReaderFindsColumnsByNameAndIgnoresExtraOnes) {
  const std::string path = ProcessTempDir::path() + "/detections.csv";
  write_file(path,
             "# detections\n"
             "score,stamp,index,x,y,z,sx,sy,sz,u0,v0,u1,v1,refined,extra\n"
             "0.9,1.000000,0,2.0,0.5,0.9,0.5,0.5,1.8,100,50,180,300,1,zz\n"
             "\n"
             "0.4,1.033333,1,3.0,-0.5,0.9,0.4,0.4,1.7,400,60,440,250,0,\n");
  const auto rows = read_detections_csv(path);
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[0].stamp_text, "1.000000");
  EXPECT_EQ(stamp_key(rows[1].stamp), stamp_key(1.033333));
  EXPECT_EQ(rows[1].index, 1);
  EXPECT_DOUBLE_EQ(rows[0].center.x(), 2.0);
  EXPECT_DOUBLE_EQ(rows[0].size.z(), 1.8);
  EXPECT_DOUBLE_EQ(rows[0].u0, 100);
  EXPECT_DOUBLE_EQ(rows[0].v1, 300);
  EXPECT_TRUE(rows[0].refined);
  EXPECT_FALSE(rows[1].refined);

  write_file(path, "stamp,u0,v0,u1\n1.0,1,2,3\n");
  try {
    (void)read_detections_csv(path);
    FAIL() << "a header without v1 was accepted";
  } catch (const ToolError& e) {
    EXPECT_NE(std::string(e.what()).find("detections.csv:1"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("v1"), std::string::npos) << e.what();
  }
  write_file(path, "stamp,u0,v0,u1,v1\n1.0,1,2,x,4\n");
  try {
    (void)read_detections_csv(path);
    FAIL() << "a malformed number was accepted";
  } catch (const ToolError& e) {
    EXPECT_NE(std::string(e.what()).find("detections.csv:2"), std::string::npos) << e.what();
  }
}

// ------------------------------------------------------------------------ analysis ------

TEST(OverlayAnalysis, MissedPeopleAndFalseDynamicTracksByTopViewDistance) {
  OverlayFrame f;  // camera at the origin looking along optical z = world z here
  f.has_reference = true;
  auto obstacle = [](int id, Eigen::Vector3d c, double speed, double visible) {
    ObstacleRecord r;
    r.id = id;
    r.center = c;
    r.size = {0.5, 0.5, 1.7};
    r.velocity = {speed, 0, 0};
    r.visible = visible;
    return r;
  };
  auto track = [](int id, Eigen::Vector3d c, bool dynamic) {
    TrackRow t;
    t.id = id;
    t.center = c;
    t.size = {0.5, 0.5, 1.7};
    t.dynamic = dynamic;
    return t;
  };
  f.reference = {obstacle(1, {0, 0, 3}, 1.0, 1.0),     // found by track 10 (0.8 m away)
                 obstacle(2, {1, 0, 3}, 1.0, 0.9),     // no dynamic track within 1 m: missed
                 obstacle(3, {-1.5, 0, 4}, 0.1, 1.0),  // too slow: not counted
                 obstacle(4, {3, 0, 3}, 1.0, 0.2)};    // mostly hidden: not counted
  // Top-view distance is in world x-y; the camera pose only decides what is "ahead".
  f.reference[1].center = {2.0, 1.0, 3.0};
  f.tracks = {track(10, {0, 0.8, 3}, true),     // near obstacle 1
              track(11, {-1.5, 0.5, 4}, true),  // near the slow obstacle 3: not false
              track(12, {8, 8, 3}, true),       // near nothing: false dynamic
              track(13, {-8, 8, 3}, false)};    // static: never false
  const FrameAnalysis a = analyse_frame(f, OverlayOptions{});
  EXPECT_EQ(a.dynamic_tracks, 3);
  EXPECT_EQ(a.static_tracks, 1);
  EXPECT_EQ(a.reference_people, 2);
  EXPECT_EQ(a.missed, 1);
  EXPECT_EQ(a.false_dynamic_count, 1);
  ASSERT_EQ(a.reference.size(), 4u);
  EXPECT_EQ(a.reference[0], ReferenceKind::kPerson);
  EXPECT_EQ(a.reference[1], ReferenceKind::kMissed);
  EXPECT_EQ(a.reference[2], ReferenceKind::kOther);
  EXPECT_EQ(a.reference[3], ReferenceKind::kOther);
  EXPECT_EQ(a.false_dynamic, (std::vector<bool>{false, false, true, false}));

  // A frame later than the result's last stamp was never replayed: nothing is judged.
  f.after_result = true;
  const FrameAnalysis late = analyse_frame(f, OverlayOptions{});
  EXPECT_EQ(late.missed + late.false_dynamic_count + late.reference_people, 0);
  f.after_result = false;

  // Without a reference nothing is judged.
  f.has_reference = false;
  const FrameAnalysis b = analyse_frame(f, OverlayOptions{});
  EXPECT_EQ(b.missed, 0);
  EXPECT_EQ(b.false_dynamic_count, 0);
  EXPECT_EQ(b.reference_people, 0);
}

// ---------------------------------------------------------------------- end to end ------

namespace {

// 40 frames of env_c with a hand-made result: track 1 follows the true person seen in the most
// frames, track 2 is a dynamic track standing where no obstacle ever comes, track 3 is static.
struct Fixture {
  std::string seq, result;
  Sequence sequence;
  int person = -1;
  std::vector<ObstacleRecord> truth;
};

bool counted(const ObstacleRecord& o, const PoseD& pose) {
  const double depth = (pose.rotation.conjugate() * (o.center - pose.translation)).z();
  return o.velocity.norm() >= 0.2 && o.visible >= 0.5 && depth >= 0.5 && depth <= 5.0;
}

const Fixture& fixture() {
  static Fixture fx = [] {
    Fixture f;
    f.seq = ProcessTempDir::path() + "/env_c";
    f.result = ProcessTempDir::path() + "/env_c_result";
    sim::SimulateOptions so;
    so.frames = 40;
    so.picture = false;
    sim::simulate(sim::make_scene("env_c", 1), f.seq, so);
    f.sequence = read_sequence(f.seq);
    f.truth = read_obstacles(f.seq + "/obstacles.txt");
    std::map<int, int> seen;
    std::map<std::int64_t, PoseD> pose_at;
    for (const auto& fr : f.sequence.frames) pose_at[stamp_key(fr.stamp)] = fr.pose;
    for (const auto& o : f.truth) seen[o.id] += counted(o, pose_at.at(stamp_key(o.stamp))) ? 1 : 0;
    for (const auto& [id, n] : seen) {
      if (f.person < 0 || n > seen[f.person]) f.person = id;
    }
    fs::create_directories(f.result);
    std::ofstream out(f.result + "/tracks.csv");
    out << "stamp,id,x,y,z,vx,vy,vz,sx,sy,sz,dynamic,path\n";
    for (const auto& o : f.truth) {
      if (o.id != f.person) continue;
      out << o.stamp_text << ",1," << o.center.x() << "," << o.center.y() << "," << o.center.z()
          << "," << o.velocity.x() << "," << o.velocity.y() << ",0,0.5,0.5,1.7,1,-1\n";
    }
    for (const auto& fr : f.sequence.frames) {
      // 50 m away from everything: a false dynamic track, and a static one beside it.
      out << fr.stamp_text << ",2,50,50,0.9,0.5,0,0,0.5,0.5,1.7,1,-1\n";
      out << fr.stamp_text << ",3,50,52,0.9,0,0,0,0.5,0.5,1.7,0,-1\n";
    }
    return f;
  }();
  return fx;
}

}  // namespace

TEST(OverlayRun, WritesPicturesAndSheetCountsMissedAndFalseAndSurvivesMissingDepth) {
  const Fixture& f = fixture();
  ASSERT_EQ(f.sequence.frames.size(), 40u);
  ASSERT_GE(f.person, 0);
  // Frame 10 is drawn (every 10th) and listed, but its depth file is gone.
  const std::string gone = f.sequence.frames[10].depth_path;
  const std::string kept = gone + ".kept";
  fs::rename(gone, kept);

  RunOptions o;
  o.seq = f.seq;
  o.result_dir = f.result;
  o.out_dir = ProcessTempDir::path() + "/overlay_out";
  o.every = 10;
  o.sheet_columns = 6;
  o.sheet_tiles = 12;
  const RunSummary s = run_overlay(o);
  fs::rename(kept, gone);

  EXPECT_EQ(s.frames, 40u);
  EXPECT_EQ(s.pictures, 4u);
  EXPECT_EQ(s.tiles, 12u);
  EXPECT_EQ(s.depth_missing, 1u);  // frame 10: once, though both a picture and a tile
  ASSERT_EQ(s.depth_errors.size(), 1u);
  EXPECT_NE(s.depth_errors[0].find(gone), std::string::npos) << s.depth_errors[0];
  EXPECT_TRUE(s.has_reference);
  EXPECT_FALSE(s.has_detections);

  const PictureSize frame_size = frame_picture_size(f.sequence.camera);
  EXPECT_GE(frame_size.width, f.sequence.camera.width);
  for (const char* name :
       {"frame_00000.png", "frame_00010.png", "frame_00020.png", "frame_00030.png"}) {
    const auto size = png_size(o.out_dir + "/" + name);
    EXPECT_EQ(size.first, frame_size.width) << name;
    EXPECT_EQ(size.second, frame_size.height) << name;
  }
  EXPECT_FALSE(fs::exists(o.out_dir + "/frame_00005.png"));
  EXPECT_FALSE(fs::exists(o.out_dir + "/frame_00040.png"));
  const PictureSize sheet_size = contact_sheet_size(f.sequence.camera, 12, 6);
  const auto sheet = png_size(o.out_dir + "/contact_sheet.png");
  EXPECT_EQ(sheet.first, sheet_size.width);
  EXPECT_EQ(sheet.second, sheet_size.height);
  // Six columns fit a README: about 900-1300 px wide.
  EXPECT_GE(sheet.first, 900);
  EXPECT_LE(sheet.first, 1300);

  // Every frame: track 2 is the only false dynamic track; missed are the counted people other
  // than the one track 1 follows.
  ASSERT_EQ(s.missed_per_frame.size(), 40u);
  std::size_t people = 0, missed = 0, person_counted = 0;
  for (std::size_t i = 0; i < 40; ++i) {
    const auto key = stamp_key(f.sequence.frames[i].stamp);
    int expect_missed = 0;
    for (const auto& ob : f.truth) {
      if (stamp_key(ob.stamp) != key || !counted(ob, f.sequence.frames[i].pose)) continue;
      ++people;
      if (ob.id == f.person) {
        ++person_counted;
      } else {
        ++expect_missed;
      }
    }
    missed += expect_missed;
    EXPECT_EQ(s.missed_per_frame[i], expect_missed) << "frame " << i;
    EXPECT_EQ(s.false_per_frame[i], 1) << "frame " << i;
  }
  EXPECT_GT(person_counted, 10u);  // the followed person is really in view
  EXPECT_EQ(s.reference_people, people);
  EXPECT_EQ(s.missed, missed);
  EXPECT_EQ(s.false_dynamic, 40u);
  std::size_t person_rows = 0;  // track 1's rows: one per frame that lists the person
  for (const auto& ob : f.truth) person_rows += ob.id == f.person ? 1 : 0;
  EXPECT_EQ(s.dynamic_tracks, 40u + person_rows);
}

TEST(OverlayRun, WithoutReferenceNothingIsJudgedAndBadInputNamesTheFile) {
  const Fixture& f = fixture();
  // A sequence copy without obstacles.txt: read the same frames, judge nothing.
  const std::string seq = ProcessTempDir::path() + "/env_c_noref";
  fs::create_directories(seq);
  for (const char* name : {"depth.txt", "groundtruth.txt", "camera.txt"}) {
    fs::copy_file(f.seq + "/" + name, seq + "/" + name, fs::copy_options::overwrite_existing);
  }
  fs::create_directory_symlink(f.seq + "/depth", seq + "/depth");
  RunOptions o;
  o.seq = seq;
  o.result_dir = f.result;
  o.out_dir = ProcessTempDir::path() + "/overlay_noref";
  o.every = 0;
  o.sheet_tiles = 6;
  o.max_frames = 12;
  const RunSummary s = run_overlay(o);
  EXPECT_FALSE(s.has_reference);
  EXPECT_EQ(s.frames, 12u);
  EXPECT_EQ(s.pictures, 0u);
  EXPECT_EQ(s.tiles, 6u);
  EXPECT_EQ(s.missed + s.false_dynamic, 0u);
  EXPECT_TRUE(fs::exists(o.out_dir + "/contact_sheet.png"));

  // --reference names a file that is not there: an error naming it.
  o.reference = seq + "/no_such_obstacles.txt";
  try {
    (void)run_overlay(o);
    FAIL() << "a missing reference file was accepted";
  } catch (const ToolError& e) {
    EXPECT_NE(std::string(e.what()).find("no_such_obstacles.txt"), std::string::npos) << e.what();
  }
}
