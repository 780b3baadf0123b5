#include "label/labeller.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <limits>
#include <unordered_map>

#include <cairo.h>

#include "common/png_io.hpp"
#include "common/sequence.hpp"
#include "common/text_io.hpp"

namespace dynamap::tools::label {
namespace {

// Dense voxel grid of per-voxel frame counts: in how many frames a voxel held a measured point
// (hits) and in how many a ray crossed it to a farther point (passes). Each is counted at most
// once per frame (stamps), so the ratio reads "share of the frames that saw it occupied".
class VoxelGrid {
 public:
  VoxelGrid(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, double res) : res_(res) {
    for (int a = 0; a < 3; ++a) {
      // Aligned to multiples of res in world coordinates (the floor falls on a voxel boundary).
      origin_[a] = std::floor(lo[a] / res) * res;
      n_[a] = std::max(1, static_cast<int>(std::ceil((hi[a] - origin_[a]) / res)));
    }
    const std::size_t total = static_cast<std::size_t>(n_[0]) * n_[1] * n_[2];
    hits_.assign(total, 0);
    passes_.assign(total, 0);
    hit_stamp_.assign(total, 0);
    pass_stamp_.assign(total, 0);
  }

  std::size_t size() const { return hits_.size(); }
  const int* dims() const { return n_; }

  bool cell(const Eigen::Vector3d& p, int* c) const {
    for (int a = 0; a < 3; ++a) {
      const double f = std::floor((p[a] - origin_[a]) / res_);
      if (!(f >= 0.0 && f < n_[a])) return false;
      c[a] = static_cast<int>(f);
    }
    return true;
  }
  std::size_t index(int i, int j, int k) const {
    return (static_cast<std::size_t>(k) * n_[1] + j) * n_[0] + i;
  }

  void hit(const Eigen::Vector3d& p, std::uint16_t stamp) {
    int c[3];
    if (!cell(p, c)) return;
    const std::size_t id = index(c[0], c[1], c[2]);
    if (hit_stamp_[id] == stamp) return;
    hit_stamp_[id] = stamp;
    if (hits_[id] < 0xFFFF) ++hits_[id];
  }

  // Marks every voxel the segment o + t * dir, t in [0, t_end], enters (Amanatides-Woo walk),
  // clipped to the grid box.
  void carve(const Eigen::Vector3d& o, const Eigen::Vector3d& dir, double t_end,
             std::uint16_t stamp) {
    double t0 = 0.0, t1 = t_end;
    for (int a = 0; a < 3; ++a) {
      const double lo = origin_[a], hi = origin_[a] + n_[a] * res_;
      if (std::abs(dir[a]) < 1e-12) {
        if (o[a] < lo || o[a] >= hi) return;
        continue;
      }
      double ta = (lo - o[a]) / dir[a], tb = (hi - o[a]) / dir[a];
      if (ta > tb) std::swap(ta, tb);
      t0 = std::max(t0, ta);
      t1 = std::min(t1, tb);
    }
    if (t0 >= t1) return;
    const Eigen::Vector3d p = o + dir * (t0 + 1e-9);
    int c[3], step[3];
    double t_max[3], t_delta[3];
    for (int a = 0; a < 3; ++a) {
      c[a] = std::clamp(static_cast<int>(std::floor((p[a] - origin_[a]) / res_)), 0, n_[a] - 1);
      if (dir[a] > 0) {
        step[a] = 1;
        t_max[a] = (origin_[a] + (c[a] + 1) * res_ - o[a]) / dir[a];
        t_delta[a] = res_ / dir[a];
      } else if (dir[a] < 0) {
        step[a] = -1;
        t_max[a] = (origin_[a] + c[a] * res_ - o[a]) / dir[a];
        t_delta[a] = -res_ / dir[a];
      } else {
        step[a] = 0;
        t_max[a] = std::numeric_limits<double>::infinity();
        t_delta[a] = t_max[a];
      }
    }
    for (;;) {
      const std::size_t id = index(c[0], c[1], c[2]);
      if (pass_stamp_[id] != stamp) {
        pass_stamp_[id] = stamp;
        if (passes_[id] < 0xFFFF) ++passes_[id];
      }
      const int a =
          t_max[0] < t_max[1] ? (t_max[0] < t_max[2] ? 0 : 2) : (t_max[1] < t_max[2] ? 1 : 2);
      if (t_max[a] >= t1) return;
      c[a] += step[a];
      if (c[a] < 0 || c[a] >= n_[a]) return;
      t_max[a] += t_delta[a];
    }
  }

  Eigen::Vector3d centre(int i, int j, int k) const {
    return origin_ + res_ * Eigen::Vector3d(i + 0.5, j + 0.5, k + 0.5);
  }
  std::uint16_t hits(std::size_t id) const { return hits_[id]; }
  std::uint16_t passes(std::size_t id) const { return passes_[id]; }

 private:
  double res_;
  Eigen::Vector3d origin_;
  int n_[3] = {1, 1, 1};
  std::vector<std::uint16_t> hits_, passes_, hit_stamp_, pass_stamp_;
};

// True when the pixel and its four neighbours `step` pixels away (those inside the image) have no
// depth: a solid no-return region (nothing within the sensor's range), not an edge dropout.
bool no_return_block(const Image16& depth, int u, int v, int step) {
  const int du[4] = {step, -step, 0, 0}, dv[4] = {0, 0, step, -step};
  for (int k = 0; k < 4; ++k) {
    const int a = u + du[k], b = v + dv[k];
    if (a >= 0 && b >= 0 && a < depth.width && b < depth.height && depth.at(a, b) != 0) {
      return false;
    }
  }
  return depth.at(u, v) == 0;
}

// A person-like cluster of dynamic points in one frame.
struct Detection {
  int frame = 0;
  Eigen::Vector2d centroid = Eigen::Vector2d::Zero();  // top view, of the visible surface
  Eigen::Vector2d camera = Eigen::Vector2d::Zero();
  double half_width = 0.0;  // across the viewing direction
  double top = 0.0;         // m above the floor
  double visible = 0.0;
  int points = 0;
};

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  const std::size_t k = std::min(v.size() - 1, static_cast<std::size_t>(q * (v.size() - 1) + 0.5));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

double median(std::vector<double> v) {
  return percentile(std::move(v), 0.5);
}

// Estimated visible fraction: the share of the box's projected image rectangle that lies in the
// image and is not hidden by nearer depth (sampled every 4th pixel). Not a silhouette: a rough
// stand-in for the simulator's visible-pixel ratio.
double estimate_visible(const Image16& depth, const CameraModel& cam, const PoseD& pose,
                        const Eigen::Vector3d& center, const Eigen::Vector3d& size) {
  const Eigen::Matrix3d Rt = pose.rotation.toRotationMatrix().transpose();
  double umin = 1e18, umax = -1e18, vmin = 1e18, vmax = -1e18, near = 1e18;
  for (int corner = 0; corner < 8; ++corner) {
    const Eigen::Vector3d off(corner & 1 ? 0.5 : -0.5, corner & 2 ? 0.5 : -0.5,
                              corner & 4 ? 0.5 : -0.5);
    const Eigen::Vector3d pc = Rt * (center + off.cwiseProduct(size) - pose.translation);
    if (pc.z() < 0.1) return 0.0;  // box reaches behind the camera: not a fair estimate
    const double u = cam.fx * pc.x() / pc.z() + cam.cx, v = cam.fy * pc.y() / pc.z() + cam.cy;
    umin = std::min(umin, u);
    umax = std::max(umax, u);
    vmin = std::min(vmin, v);
    vmax = std::max(vmax, v);
    near = std::min(near, pc.z());
  }
  const double area = (umax - umin) * (vmax - vmin);
  if (area < 1.0) return 0.0;
  const int u0 = std::max(0, static_cast<int>(std::ceil(umin)));
  const int u1 = std::min(depth.width - 1, static_cast<int>(std::floor(umax)));
  const int v0 = std::max(0, static_cast<int>(std::ceil(vmin)));
  const int v1 = std::min(depth.height - 1, static_cast<int>(std::floor(vmax)));
  if (u0 > u1 || v0 > v1) return 0.0;
  long seen = 0, samples = 0;
  const double occluder = (near - 0.3) * cam.depth_factor;
  for (int v = v0; v <= v1; v += 4) {
    for (int u = u0; u <= u1; u += 4) {
      ++samples;
      const std::uint16_t d = depth.at(u, v);
      if (d == 0 || d >= occluder) ++seen;
    }
  }
  const double inside = static_cast<double>(u1 - u0 + 1) * (v1 - v0 + 1) / area;
  return std::clamp(inside * static_cast<double>(seen) / static_cast<double>(samples), 0.0, 1.0);
}

// Top-view connected components (8-neighbour) of points on a cell grid.
std::vector<std::vector<int>> cluster_top_view(const std::vector<Eigen::Vector3d>& pts,
                                               double cell) {
  // Cell (i, j) packed into 64 bits through unsigned casts (no shifts of negative numbers).
  auto key = [](std::int32_t i, std::int32_t j) {
    return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(i)) << 32) |
           static_cast<std::uint32_t>(j);
  };
  std::unordered_map<std::uint64_t, std::vector<int>> cells;
  for (std::size_t n = 0; n < pts.size(); ++n) {
    const auto i = static_cast<std::int32_t>(std::floor(pts[n].x() / cell));
    const auto j = static_cast<std::int32_t>(std::floor(pts[n].y() / cell));
    cells[key(i, j)].push_back(static_cast<int>(n));
  }
  std::unordered_map<std::uint64_t, bool> done;
  std::vector<std::vector<int>> clusters;
  for (const auto& entry : cells) {
    if (done[entry.first]) continue;
    std::vector<std::uint64_t> stack{entry.first};
    done[entry.first] = true;
    std::vector<int> members;
    while (!stack.empty()) {
      const std::uint64_t k = stack.back();
      stack.pop_back();
      const auto& m = cells.at(k);
      members.insert(members.end(), m.begin(), m.end());
      const auto i = static_cast<std::int32_t>(static_cast<std::uint32_t>(k >> 32));
      const auto j = static_cast<std::int32_t>(static_cast<std::uint32_t>(k & 0xFFFFFFFFull));
      for (std::int32_t di = -1; di <= 1; ++di) {
        for (std::int32_t dj = -1; dj <= 1; ++dj) {
          const std::uint64_t nk = key(i + di, j + dj);
          if (cells.count(nk) == 0 || done[nk]) continue;
          done[nk] = true;
          stack.push_back(nk);
        }
      }
    }
    clusters.push_back(std::move(members));
  }
  return clusters;
}

// Local line fit x(t) = a + b (t - tc) over samples; returns false with fewer than 2 samples.
bool line_fit(const std::vector<double>& t, const std::vector<Eigen::Vector2d>& x, int lo, int hi,
              double tc, Eigen::Vector2d* a, Eigen::Vector2d* b) {
  const int n = hi - lo + 1;
  if (n < 2) return false;
  double st = 0.0;
  Eigen::Vector2d sx = Eigen::Vector2d::Zero();
  for (int k = lo; k <= hi; ++k) {
    st += t[k] - tc;
    sx += x[k];
  }
  const double mt = st / n;
  const Eigen::Vector2d mx = sx / n;
  double stt = 0.0;
  Eigen::Vector2d stx = Eigen::Vector2d::Zero();
  for (int k = lo; k <= hi; ++k) {
    const double dt = t[k] - tc - mt;
    stt += dt * dt;
    stx += dt * (x[k] - mx);
  }
  if (stt <= 0.0) return false;
  *b = stx / stt;
  *a = mx - *b * mt;
  return true;
}

struct Track {
  std::vector<Detection> dets;  // increasing frame
  Eigen::Vector2d velocity_per_frame() const {
    const std::size_t n = dets.size();
    if (n < 2) return Eigen::Vector2d::Zero();
    const std::size_t k = n >= 6 ? n - 6 : 0;
    const int df = dets[n - 1].frame - dets[k].frame;
    return df > 0 ? Eigen::Vector2d((dets[n - 1].centroid - dets[k].centroid) / df)
                  : Eigen::Vector2d::Zero();
  }
};

// Depth (grey, near = bright), points held free by the model (red) and labelled boxes (green).
void write_overlay(const std::string& path, const Image16& depth, const CameraModel& cam,
                   const PoseD& pose, const std::vector<Eigen::Vector3d>& free_points,
                   const std::vector<const ObstacleRecord*>& rows) {
  cairo_surface_t* s = cairo_image_surface_create(CAIRO_FORMAT_RGB24, depth.width, depth.height);
  cairo_surface_flush(s);
  unsigned char* data = cairo_image_surface_get_data(s);
  const int stride = cairo_image_surface_get_stride(s);
  for (int v = 0; v < depth.height; ++v) {
    auto* row = reinterpret_cast<std::uint32_t*>(data + static_cast<std::ptrdiff_t>(v) * stride);
    for (int u = 0; u < depth.width; ++u) {
      const double z = depth.at(u, v) / cam.depth_factor;
      const auto g =
          z <= 0.0 ? 0u
                   : static_cast<std::uint32_t>(std::clamp(255.0 * (1.0 - z / 8.0), 0.0, 255.0));
      row[u] = z <= 0.0 ? 0x00400000u : (g << 16) | (g << 8) | g;
    }
  }
  cairo_surface_mark_dirty(s);
  cairo_t* cr = cairo_create(s);
  const Eigen::Matrix3d Rt = pose.rotation.toRotationMatrix().transpose();
  auto project = [&](const Eigen::Vector3d& w, double* u, double* v) {
    const Eigen::Vector3d pc = Rt * (w - pose.translation);
    if (pc.z() < 0.1) return false;
    *u = cam.fx * pc.x() / pc.z() + cam.cx;
    *v = cam.fy * pc.y() / pc.z() + cam.cy;
    return true;
  };
  cairo_set_source_rgb(cr, 0.9, 0.1, 0.1);
  for (const auto& p : free_points) {
    double u = 0.0, v = 0.0;
    if (project(p, &u, &v)) cairo_rectangle(cr, u - 1, v - 1, 2, 2);
  }
  cairo_fill(cr);
  cairo_set_line_width(cr, 2.0);
  for (const ObstacleRecord* r : rows) {
    double umin = 1e9, umax = -1e9, vmin = 1e9, vmax = -1e9;
    bool ok = true;
    for (int c = 0; c < 8 && ok; ++c) {
      const Eigen::Vector3d off(c & 1 ? 0.5 : -0.5, c & 2 ? 0.5 : -0.5, c & 4 ? 0.5 : -0.5);
      double u = 0.0, v = 0.0;
      ok = project(r->center + off.cwiseProduct(r->size), &u, &v);
      if (!ok) break;  // box reaches behind the camera: not drawn
      umin = std::min(umin, u);
      umax = std::max(umax, u);
      vmin = std::min(vmin, v);
      vmax = std::max(vmax, v);
    }
    if (!ok) continue;
    if (r->visible > 0.0) {
      cairo_set_source_rgb(cr, 0.1, 0.9, 0.1);
    } else {
      cairo_set_source_rgb(cr, 0.1, 0.6, 0.9);  // interpolated
    }
    cairo_rectangle(cr, umin, vmin, umax - umin, vmax - vmin);
    cairo_stroke(cr);
    char buf[96];
    std::snprintf(buf, sizeof(buf), "%d  %.1f m/s", r->id, r->velocity.head<2>().norm());
    cairo_move_to(cr, std::max(2.0, umin + 3), std::max(14.0, vmin + 16));
    cairo_set_font_size(cr, 14);
    cairo_show_text(cr, buf);
  }
  cairo_destroy(cr);
  const cairo_status_t st = cairo_surface_write_to_png(s, path.c_str());
  cairo_surface_destroy(s);
  if (st != CAIRO_STATUS_SUCCESS) throw ToolError(path + ": cannot write overlay PNG");
}

// The model's static voxels (state 2) as centres with their hit ratio.
std::vector<MapVoxel> static_voxels(const VoxelGrid& grid, const std::vector<std::uint8_t>& state) {
  std::vector<MapVoxel> out;
  const int* n = grid.dims();
  for (int k = 0; k < n[2]; ++k) {
    for (int j = 0; j < n[1]; ++j) {
      for (int i = 0; i < n[0]; ++i) {
        const std::size_t id = grid.index(i, j, k);
        if (state[id] != 2) continue;
        const double h = grid.hits(id), obs = h + grid.passes(id);
        MapVoxel m;
        m.centre = grid.centre(i, j, k).cast<float>();
        m.probability = static_cast<float>(h / obs);
        out.push_back(m);
      }
    }
  }
  return out;
}

void say(const LabelOptions& opt, const std::string& s) {
  if (opt.progress) opt.progress(s);
}

// The depth image of frame f, or false when it cannot be read (no throw).
bool load(const Sequence& seq, std::size_t f, Image16* img) {
  try {
    *img = load_depth(seq, seq.frames[f]);
    return true;
  } catch (const ToolError&) {
    return false;
  }
}

// Reads the sequence, notes its warnings, drops the first first_frame frames and counts the
// frames to label (max_frames) into sum.frames.
Sequence open_sequence(const std::string& seq_dir, const LabelOptions& opt, LabelSummary& sum) {
  Sequence seq = read_sequence(seq_dir);
  sum.listed = seq.images_listed;
  sum.without_pose = seq.images_without_pose;
  // A world_z_up 0 sequence is read gravity-aligned and levelled on its floor (z = 0); when no
  // floor was found its heights are only guesses.
  if (seq.camera.world_z_up != 1 && !seq.floor_levelled) {
    sum.warnings.push_back(join_path(seq_dir, "camera.txt") +
                           ": no 'world_z_up 1' and no floor found: the floor is assumed at z = " +
                           std::to_string(opt.floor_z) + " of the gravity-aligned world");
  }
  for (const std::string& w : seq.warnings) sum.warnings.push_back(w);
  const auto first =
      std::min(seq.frames.size(), static_cast<std::size_t>(std::max(0, opt.first_frame)));
  seq.frames.erase(seq.frames.begin(), seq.frames.begin() + static_cast<std::ptrdiff_t>(first));
  std::size_t nframes = seq.frames.size();
  if (opt.max_frames > 0) nframes = std::min(nframes, static_cast<std::size_t>(opt.max_frames));
  sum.frames = nframes;
  return seq;
}

// Grid bounds: every camera position +- max range in x / y (capped), floor to 3.5 m above.
VoxelGrid make_grid(const Sequence& seq, std::size_t nframes, const LabelOptions& opt) {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e18), hi = Eigen::Vector3d::Constant(-1e18);
  for (std::size_t f = 0; f < nframes; ++f) {
    lo = lo.cwiseMin(seq.frames[f].pose.translation);
    hi = hi.cwiseMax(seq.frames[f].pose.translation);
  }
  for (int a = 0; a < 2; ++a) {
    const double mid = 0.5 * (lo[a] + hi[a]);
    lo[a] = std::max(lo[a] - opt.max_range, mid - 0.5 * opt.max_extent);
    hi[a] = std::min(hi[a] + opt.max_range, mid + 0.5 * opt.max_extent);
  }
  lo.z() = opt.floor_z - 0.3;
  hi.z() = opt.floor_z + 3.5;
  return VoxelGrid(lo, hi, opt.voxel);
}

// One frame's rays into the grid (every model_stride pixels): free space up to the point (or
// max_range, or no_return_range through a solid no-return region), a hit at the point.
void add_frame_to_model(VoxelGrid& grid, const Image16& depth, const CameraModel& cam,
                        const PoseD& pose, std::uint16_t stamp, const LabelOptions& opt) {
  const Eigen::Matrix3d R = pose.rotation.toRotationMatrix();
  const Eigen::Vector3d o = pose.translation;
  for (int v = opt.model_stride / 2; v < depth.height; v += opt.model_stride) {
    for (int u = opt.model_stride / 2; u < depth.width; u += opt.model_stride) {
      const std::uint16_t d = depth.at(u, v);
      if (d == 0) {
        if (opt.no_return_range > 0.0 && no_return_block(depth, u, v, opt.model_stride)) {
          const Eigen::Vector3d ray =
              R * Eigen::Vector3d((u - cam.cx) / cam.fx, (v - cam.cy) / cam.fy, 1.0);
          grid.carve(o, ray.normalized(), opt.no_return_range, stamp);
        }
        continue;
      }
      const double z = d / cam.depth_factor;
      const Eigen::Vector3d pc((u - cam.cx) * z / cam.fx, (v - cam.cy) * z / cam.fy, z);
      const Eigen::Vector3d p = R * pc + o;
      const double range = (p - o).norm();
      if (range < 0.2) continue;
      const Eigen::Vector3d dir = (p - o) / range;
      if (range > opt.max_range) {
        grid.carve(o, dir, opt.max_range, stamp);
      } else {
        if (range > opt.end_margin) grid.carve(o, dir, range - opt.end_margin, stamp);
        grid.hit(p, stamp);
      }
    }
  }
}

// Pass 1: every readable frame into the grid; marks the frames read in `usable` and lists the
// others in the summary.
void build_model(const Sequence& seq, std::size_t nframes, const LabelOptions& opt, VoxelGrid& grid,
                 std::vector<bool>& usable, LabelSummary& sum) {
  for (std::size_t f = 0; f < nframes; ++f) {
    const SequenceFrame& fr = seq.frames[f];
    Image16 depth;
    try {
      depth = load_depth(seq, fr);
    } catch (const ToolError& e) {
      sum.skipped.push_back(e.what());
      say(opt, std::string("skipping frame ") + fr.stamp_text + ": " + e.what());
      continue;
    }
    usable[f] = true;
    ++sum.frames_used;
    const auto stamp = static_cast<std::uint16_t>((f % 0xFFFF) + 1);
    add_frame_to_model(grid, depth, seq.camera, fr.pose, stamp, opt);
    if ((f + 1) % 100 == 0 || f + 1 == nframes) {
      say(opt, "model: " + std::to_string(f + 1) + "/" + std::to_string(nframes) + " frames");
    }
  }
}

// Voxel states: 0 unknown / between, 1 free (seen often, rarely occupied), 2 static (often
// occupied).
std::vector<std::uint8_t> classify_voxels(const VoxelGrid& grid, const LabelOptions& opt) {
  std::vector<std::uint8_t> state(grid.size(), 0);
  for (std::size_t id = 0; id < grid.size(); ++id) {
    const double h = grid.hits(id), obs = h + grid.passes(id);
    if (obs < opt.min_observations) continue;
    if (h < opt.free_ratio * obs) {
      state[id] = 1;
    } else if (h >= opt.static_ratio * obs) {
      state[id] = 2;
    }
  }
  return state;
}

// The "dynamic-capable" voxels: free with no static neighbour (absorbs pose and depth noise at
// walls and the floor).
std::vector<std::uint8_t> dynamic_capable(const VoxelGrid& grid,
                                          const std::vector<std::uint8_t>& state) {
  const int* n = grid.dims();
  std::vector<std::uint8_t> dynamic_ok(grid.size(), 0);
  for (int k = 0; k < n[2]; ++k) {
    for (int j = 0; j < n[1]; ++j) {
      for (int i = 0; i < n[0]; ++i) {
        const std::size_t id = grid.index(i, j, k);
        if (state[id] != 1) continue;
        bool ok = true;
        for (int dk = -1; dk <= 1 && ok; ++dk) {
          for (int dj = -1; dj <= 1 && ok; ++dj) {
            for (int di = -1; di <= 1 && ok; ++di) {
              const int a = i + di, b = j + dj, c = k + dk;
              if (a < 0 || b < 0 || c < 0 || a >= n[0] || b >= n[1] || c >= n[2]) continue;
              ok = state[grid.index(a, b, c)] != 2;
            }
          }
        }
        dynamic_ok[id] = ok ? 1 : 0;
      }
    }
  }
  return dynamic_ok;
}

// The pass 1 result: the grid with its voxel states, and the points a frame has in space the
// model holds free.
class StaticModel {
 public:
  StaticModel(VoxelGrid grid, const LabelOptions& opt, const CameraModel& cam)
      : grid_(std::move(grid)),
        state_(classify_voxels(grid_, opt)),
        dynamic_ok_(dynamic_capable(grid_, state_)),
        opt_(opt),
        cam_(cam) {}

  std::vector<MapVoxel> static_model_voxels() const { return static_voxels(grid_, state_); }

  // Points of a frame in space the model holds free: the candidates of moving people. Only
  // points whose 3x3 image neighbourhood (at detect_stride) is mostly free count: depth noise
  // leaves scattered free points on walls seen at grazing angles, a person is a solid region.
  std::vector<Eigen::Vector3d> free_points(const Image16& depth, const PoseD& pose) const {
    const int gw = (depth.width + opt_.detect_stride - 1) / opt_.detect_stride;
    const int gh = (depth.height + opt_.detect_stride - 1) / opt_.detect_stride;
    std::vector<std::uint8_t> is_free(static_cast<std::size_t>(gw) * gh, 0);
    std::vector<Eigen::Vector3d> world(is_free.size());
    mark_free(depth, pose, gw, gh, is_free, world);
    const Eigen::Vector3d o = pose.translation;
    std::vector<Eigen::Vector3d> pts;
    for (int gv = 0; gv < gh; ++gv) {
      for (int gu = 0; gu < gw; ++gu) {
        const std::size_t k = static_cast<std::size_t>(gv) * gw + gu;
        if (!is_free[k]) continue;
        const Eigen::Vector3d& p = world[k];
        if (p.z() < opt_.floor_z + opt_.min_point_height || (p - o).norm() > opt_.detect_range) {
          continue;
        }
        int count = 0;
        for (int dv = -1; dv <= 1; ++dv) {
          for (int du = -1; du <= 1; ++du) {
            const int a = gu + du, b = gv + dv;
            if (a >= 0 && b >= 0 && a < gw && b < gh) {
              count += is_free[static_cast<std::size_t>(b) * gw + a];
            }
          }
        }
        if (count >= opt_.min_free_neighbours) pts.push_back(p);
      }
    }
    return pts;
  }

 private:
  // Depth noise grows with range: a far point can land well in front of the wall it belongs
  // to. Such a point has a static voxel just behind it on its ray.
  bool static_behind(const Eigen::Vector3d& o, const Eigen::Vector3d& p) const {
    const double r = (p - o).norm();
    const Eigen::Vector3d dir = (p - o) / r;
    const double reach = opt_.behind_check + opt_.behind_check_quadratic * r * r;
    for (double s = 0.5 * opt_.voxel; s <= reach; s += 0.5 * opt_.voxel) {
      int c[3];
      if (grid_.cell(p + s * dir, c) && state_[grid_.index(c[0], c[1], c[2])] == 2) return true;
    }
    return false;
  }

  // The sample grid (every detect_stride pixels) of the image: 1 where the point lies in a
  // dynamic-capable voxel with no static voxel just behind it, with its world position.
  void mark_free(const Image16& depth, const PoseD& pose, int gw, int gh,
                 std::vector<std::uint8_t>& is_free, std::vector<Eigen::Vector3d>& world) const {
    const Eigen::Matrix3d R = pose.rotation.toRotationMatrix();
    const Eigen::Vector3d o = pose.translation;
    for (int gv = 0; gv < gh; ++gv) {
      for (int gu = 0; gu < gw; ++gu) {
        const int u = gu * opt_.detect_stride, v = gv * opt_.detect_stride;
        const std::uint16_t d = depth.at(u, v);
        if (d == 0) continue;
        const double z = d / cam_.depth_factor;
        const Eigen::Vector3d pc((u - cam_.cx) * z / cam_.fx, (v - cam_.cy) * z / cam_.fy, z);
        const Eigen::Vector3d p = R * pc + o;
        int c[3];
        if (!grid_.cell(p, c) || !dynamic_ok_[grid_.index(c[0], c[1], c[2])]) continue;
        if (static_behind(o, p)) continue;
        const std::size_t k = static_cast<std::size_t>(gv) * gw + gu;
        is_free[k] = 1;
        world[k] = p;
      }
    }
  }

  VoxelGrid grid_;
  std::vector<std::uint8_t> state_;
  std::vector<std::uint8_t> dynamic_ok_;
  const LabelOptions& opt_;
  const CameraModel& cam_;
};

// A cluster of free points as a person, or false when its size or height does not fit one.
bool person_of(const std::vector<Eigen::Vector3d>& pts, const std::vector<int>& members,
               const Image16& depth, const CameraModel& cam, const PoseD& pose, int frame,
               const LabelOptions& opt, Detection* out) {
  if (static_cast<int>(members.size()) < opt.min_points) return false;
  std::vector<double> zs, xs, ys;
  Eigen::Vector2d centroid = Eigen::Vector2d::Zero();
  for (int m : members) {
    zs.push_back(pts[m].z());
    xs.push_back(pts[m].x());
    ys.push_back(pts[m].y());
    centroid += pts[m].head<2>();
  }
  centroid /= static_cast<double>(members.size());
  const double top = percentile(zs, 0.98) - opt.floor_z;
  const double bottom = percentile(zs, 0.02) - opt.floor_z;
  const double fx = percentile(xs, 0.98) - percentile(xs, 0.02);
  const double fy = percentile(ys, 0.98) - percentile(ys, 0.02);
  if (top < opt.min_top || top - bottom < opt.min_vertical_extent) return false;
  if (std::hypot(fx, fy) > opt.max_footprint) return false;
  Detection det;
  det.frame = frame;
  det.centroid = centroid;
  det.camera = pose.translation.head<2>();
  det.top = top;
  det.points = static_cast<int>(members.size());
  const Eigen::Vector2d ray = (centroid - det.camera).normalized();
  const Eigen::Vector2d across(-ray.y(), ray.x());
  std::vector<double> w;
  for (int m : members) w.push_back(across.dot(pts[m].head<2>() - centroid));
  det.half_width = 0.5 * (percentile(w, 0.98) - percentile(w, 0.02));
  const double r = std::clamp(det.half_width, opt.min_radius, opt.max_radius);
  const Eigen::Vector2d c2 = centroid + ray * (r * M_PI / 4.0);
  det.visible = estimate_visible(depth, cam, pose, Eigen::Vector3d(c2.x(), c2.y(), 0.5 * top),
                                 Eigen::Vector3d(2 * r, 2 * r, top));
  *out = det;
  return true;
}

// Pass 2: per frame, person-like clusters of points in space the model holds free.
std::vector<std::vector<Detection>> detect_people(const Sequence& seq, std::size_t nframes,
                                                  const std::vector<bool>& usable,
                                                  const StaticModel& model, const LabelOptions& opt,
                                                  LabelSummary& sum) {
  std::vector<std::vector<Detection>> dets(nframes);
  for (std::size_t f = 0; f < nframes; ++f) {
    if (!usable[f]) continue;
    const SequenceFrame& fr = seq.frames[f];
    Image16 depth;
    if (!load(seq, f, &depth)) continue;  // read in pass 1 already: only a changing file fails
    const std::vector<Eigen::Vector3d> pts = model.free_points(depth, fr.pose);
    for (const auto& members : cluster_top_view(pts, opt.cell)) {
      Detection det;
      if (!person_of(pts, members, depth, seq.camera, fr.pose, static_cast<int>(f), opt, &det)) {
        continue;
      }
      dets[f].push_back(det);
      ++sum.detections;
    }
    if ((f + 1) % 100 == 0 || f + 1 == nframes) {
      say(opt, "detect: " + std::to_string(f + 1) + "/" + std::to_string(nframes) + " frames, " +
                   std::to_string(sum.detections) + " person-like clusters");
    }
  }
  return dets;
}

// One frame of association: gated nearest neighbour with a constant-velocity guess, greedy by
// distance; a detection left over starts a track.
void associate_frame(int fi, const std::vector<Detection>& dets, const LabelOptions& opt,
                     std::vector<Track>& tracks, std::vector<std::size_t>& active) {
  active.erase(std::remove_if(active.begin(), active.end(),
                              [&](std::size_t t) {
                                return fi - tracks[t].dets.back().frame > opt.max_gap + 1;
                              }),
               active.end());
  struct Pair {
    double cost;
    std::size_t track, det;
  };
  std::vector<Pair> pairs;
  for (std::size_t t : active) {
    const Detection& last = tracks[t].dets.back();
    const int gap = fi - last.frame;
    const Eigen::Vector2d guess = last.centroid + tracks[t].velocity_per_frame() * gap;
    const double gate = opt.gate + 0.1 * (gap - 1);
    for (std::size_t d = 0; d < dets.size(); ++d) {
      const double c = (dets[d].centroid - guess).norm();
      if (c <= gate) pairs.push_back({c, t, d});
    }
  }
  std::sort(pairs.begin(), pairs.end(),
            [](const Pair& a, const Pair& b) { return a.cost < b.cost; });
  std::vector<bool> det_used(dets.size(), false);
  std::vector<std::size_t> fed;
  for (const Pair& p : pairs) {
    if (det_used[p.det] || std::find(fed.begin(), fed.end(), p.track) != fed.end()) continue;
    det_used[p.det] = true;
    fed.push_back(p.track);
    tracks[p.track].dets.push_back(dets[p.det]);
  }
  for (std::size_t d = 0; d < dets.size(); ++d) {
    if (det_used[d]) continue;
    tracks.push_back(Track{{dets[d]}});
    active.push_back(tracks.size() - 1);
  }
}

// Pass 3, association over all frames.
std::vector<Track> associate(const std::vector<std::vector<Detection>>& dets,
                             const LabelOptions& opt) {
  std::vector<Track> tracks;
  std::vector<std::size_t> active;
  for (std::size_t f = 0; f < dets.size(); ++f) {
    associate_frame(static_cast<int>(f), dets[f], opt, tracks, active);
  }
  return tracks;
}

// A track on every frame from its first to its last detection: observed centres corrected to
// the body axis, gaps filled linearly in time.
struct TrackPath {
  int f0 = 0, len = 0;
  double radius = 0.0, height = 0.0;
  std::vector<Eigen::Vector2d> pos;
  std::vector<double> vis, t;  // visible fraction (observed frames), seconds since f0
  std::vector<bool> seen;
};

TrackPath track_path(const Track& tr, const Sequence& seq, const LabelOptions& opt) {
  TrackPath p;
  std::vector<double> widths, tops;
  for (const auto& d : tr.dets) {
    widths.push_back(d.half_width);
    tops.push_back(d.top);
  }
  p.radius = std::clamp(median(widths), opt.min_radius, opt.max_radius);
  p.height = median(tops);
  const double r = p.radius;
  const int f0 = tr.dets.front().frame, f1 = tr.dets.back().frame;
  p.f0 = f0;
  p.len = f1 - f0 + 1;
  const auto len = static_cast<std::size_t>(p.len);
  p.pos.resize(len);
  p.vis.assign(len, 0.0);
  p.t.resize(len);
  p.seen.assign(len, false);
  for (const auto& d : tr.dets) {
    const Eigen::Vector2d ray = (d.centroid - d.camera).normalized();
    const auto k = static_cast<std::size_t>(d.frame - f0);
    p.pos[k] = d.centroid + ray * (r * M_PI / 4.0);
    p.vis[k] = d.visible;
    p.seen[k] = true;
  }
  for (std::size_t k = 0; k < len; ++k) {
    p.t[k] = seq.frames[static_cast<std::size_t>(f0) + k].stamp - seq.frames[f0].stamp;
  }
  for (std::size_t k = 0, prev = 0; k < len; ++k) {
    if (!p.seen[k]) continue;
    for (std::size_t g = prev + 1; g < k; ++g) {
      const double s = (p.t[g] - p.t[prev]) / (p.t[k] - p.t[prev]);
      p.pos[g] = p.pos[prev] + s * (p.pos[k] - p.pos[prev]);
    }
    prev = k;
  }
  return p;
}

// Moving only: people who stand are static world. A track cut short by the sequence's start or
// end may instead show walking by its fitted speed.
bool is_moving(const TrackPath& p, bool short_at_boundary, const LabelOptions& opt) {
  Eigen::Vector2d bmin = p.pos[0], bmax = p.pos[0];
  for (const auto& q : p.pos) {
    bmin = bmin.cwiseMin(q);
    bmax = bmax.cwiseMax(q);
  }
  bool moving = (bmax - bmin).norm() >= opt.min_travel;
  if (!moving && short_at_boundary) {
    Eigen::Vector2d a, b;
    moving =
        line_fit(p.t, p.pos, 0, p.len - 1, p.t[0], &a, &b) && b.norm() >= opt.min_boundary_speed;
  }
  return moving;
}

// The rows of a kept track: position and velocity from local line fits, one row per frame.
void append_rows(const TrackPath& p, int id, const Sequence& seq, const LabelOptions& opt,
                 LabelResult& result) {
  const int len = p.len;
  const double r = p.radius, height = p.height;
  for (int k = 0; k < len; ++k) {
    Eigen::Vector2d a, b, a2, b2;
    const int lo_p = std::max(0, k - opt.position_half_window);
    const int hi_p = std::min(len - 1, k + opt.position_half_window);
    const int lo_v = std::max(0, k - opt.velocity_half_window);
    const int hi_v = std::min(len - 1, k + opt.velocity_half_window);
    if (!line_fit(p.t, p.pos, lo_p, hi_p, p.t[k], &a, &b)) a = p.pos[k];
    if (!line_fit(p.t, p.pos, lo_v, hi_v, p.t[k], &a2, &b2)) b2.setZero();
    ObstacleRecord rec;
    const SequenceFrame& fr =
        seq.frames[static_cast<std::size_t>(p.f0) + static_cast<std::size_t>(k)];
    rec.stamp = fr.stamp;
    rec.stamp_text = fr.stamp_text;
    rec.id = id;
    rec.center = Eigen::Vector3d(a.x(), a.y(), opt.floor_z + 0.5 * height);
    rec.velocity = Eigen::Vector3d(b2.x(), b2.y(), 0.0);
    rec.size = Eigen::Vector3d(2 * r, 2 * r, height);
    const auto ks = static_cast<std::size_t>(k);
    rec.visible = p.seen[ks] ? p.vis[ks] : 0.0;
    result.rows.push_back(rec);
    if (!p.seen[ks]) ++result.summary.interpolated_rows;
  }
}

// Pass 3, the tracks' rows: long enough tracks (shorter ones when cut by the sequence's ends)
// that move, numbered from 1, rows sorted by frame, then id.
void rows_of_tracks(const std::vector<Track>& tracks, const Sequence& seq, std::size_t nframes,
                    const LabelOptions& opt, LabelResult& result) {
  int next_id = 1;
  for (const Track& tr : tracks) {
    const int ndet = static_cast<int>(tr.dets.size());
    const bool at_boundary = tr.dets.front().frame <= opt.max_gap ||
                             tr.dets.back().frame >= static_cast<int>(nframes) - 1 - opt.max_gap;
    if (ndet < (at_boundary ? opt.min_boundary_frames : opt.min_track_frames)) continue;
    const TrackPath p = track_path(tr, seq, opt);
    if (!is_moving(p, at_boundary && ndet < opt.min_track_frames, opt)) continue;
    const int id = next_id++;
    ++result.summary.tracks;
    append_rows(p, id, seq, opt, result);
  }
  std::stable_sort(result.rows.begin(), result.rows.end(),
                   [](const ObstacleRecord& a, const ObstacleRecord& b) {
                     return a.stamp != b.stamp ? a.stamp < b.stamp : a.id < b.id;
                   });
  result.summary.rows = result.rows.size();
}

// Every overlay_every-th frame: the overlay PNG for checking by eye.
void write_overlays(const Sequence& seq, std::size_t nframes, const std::vector<bool>& usable,
                    const StaticModel& model, const LabelResult& result, const LabelOptions& opt) {
  make_directories(opt.overlay_dir, "cannot create overlay directory");
  for (std::size_t f = 0; f < nframes; f += static_cast<std::size_t>(opt.overlay_every)) {
    Image16 depth;
    if (!usable[f] || !load(seq, f, &depth)) continue;
    std::vector<const ObstacleRecord*> here;
    for (const auto& r : result.rows) {
      if (r.stamp_text == seq.frames[f].stamp_text) here.push_back(&r);
    }
    char name[64];
    std::snprintf(name, sizeof(name), "frame_%05zu.png", f);
    write_overlay(join_path(opt.overlay_dir, name), depth, seq.camera, seq.frames[f].pose,
                  model.free_points(depth, seq.frames[f].pose), here);
  }
}

}  // namespace

std::string describe(const LabelOptions& o) {
  char buf[1400];
  std::snprintf(buf, sizeof(buf),
                "static voxel model (%.2f m voxels, rays every %d px to %.1f m, solid no-return "
                "regions carved to %.1f m, hits vs free passes per frame), dynamic points = voxel "
                "seen >= %d frames and occupied in "
                "< %.2f of them, no neighbour occupied >= %.2f, none within %.2f + %.3f r^2 behind "
                "on the ray, z > floor + %.2f m, within "
                "%.1f m (every %d px) with >= %d of 9 image neighbours free; top-view clusters "
                "(%.2f m cells) with >= %d points, top "
                ">= %.2f m, height >= %.2f m; tracks gated %.2f m, gaps <= %d frames "
                "interpolated, >= %d detections, travel >= %.2f m (cut by the sequence's ends: "
                ">= %d detections, speed >= %.2f m/s); centre = visible-surface "
                "centroid + (pi/4) r along the view ray (r = median half width, clamped "
                "%.2f-%.2f m); position: line fit +-%d frames, velocity: line fit +-%d frames",
                o.voxel, o.model_stride, o.max_range, o.no_return_range, o.min_observations,
                o.free_ratio, o.static_ratio, o.behind_check, o.behind_check_quadratic,
                o.min_point_height, o.detect_range, o.detect_stride, o.min_free_neighbours, o.cell,
                o.min_points, o.min_top, o.min_vertical_extent, o.gate, o.max_gap,
                o.min_track_frames, o.min_travel, o.min_boundary_frames, o.min_boundary_speed,
                o.min_radius, o.max_radius, o.position_half_window, o.velocity_half_window);
  return buf;
}

LabelResult label_sequence(const std::string& seq_dir, const LabelOptions& opt) {
  const auto t_start = std::chrono::steady_clock::now();
  LabelResult result;
  LabelSummary& sum = result.summary;
  const Sequence seq = open_sequence(seq_dir, opt, sum);
  const std::size_t nframes = sum.frames;
  if (nframes > 0) {
    VoxelGrid grid = make_grid(seq, nframes, opt);
    std::vector<bool> usable(nframes, false);
    build_model(seq, nframes, opt, grid, usable, sum);
    const StaticModel model(std::move(grid), opt, seq.camera);
    if (opt.keep_static_model) result.static_model = model.static_model_voxels();
    const std::vector<Track> tracks =
        associate(detect_people(seq, nframes, usable, model, opt, sum), opt);
    rows_of_tracks(tracks, seq, nframes, opt, result);
    if (opt.overlay_every > 0 && !opt.overlay_dir.empty()) {
      write_overlays(seq, nframes, usable, model, result, opt);
    }
  }
  sum.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  return result;
}

void write_labels(const std::string& out_dir, const LabelResult& result,
                  const LabelOptions& options) {
  make_directories(out_dir, "cannot create output directory");
  const std::string obs_path = join_path(out_dir, "obstacles.txt");
  const std::string csv_path = join_path(out_dir, "tracks.csv");
  std::ofstream obs(obs_path), csv(csv_path);
  if (!obs) throw ToolError(obs_path + ": cannot open for writing");
  if (!csv) throw ToolError(csv_path + ": cannot open for writing");
  obs << "# reference labels made by dynamap-label from the depth data (no human labels): "
      << describe(options) << "\n"
      << "# visible = estimated share of the box's image rectangle inside the image and not "
         "hidden by nearer depth; 0 on interpolated frames\n";
  write_obstacles_header(obs, "reference obstacles (moving people found in the depth data)");
  csv << "stamp,id,x,y,z,vx,vy,vz,sx,sy,sz,dynamic,path\n";
  for (const ObstacleRecord& r : result.rows) {
    write_obstacle_line(obs, r);
    char buf[320];
    std::snprintf(buf, sizeof(buf), "%s,%d,%.4f,%.4f,%.4f,%.4f,%.4f,%.4f,%.3f,%.3f,%.3f,1,-1\n",
                  r.stamp_text.c_str(), r.id, r.center.x(), r.center.y(), r.center.z(),
                  r.velocity.x(), r.velocity.y(), r.velocity.z(), r.size.x(), r.size.y(),
                  r.size.z());
    csv << buf;
  }
  obs.flush();
  csv.flush();
  if (!obs) throw ToolError(obs_path + ": write error");
  if (!csv) throw ToolError(csv_path + ": write error");
  if (options.keep_static_model) {
    write_map_ply(join_path(out_dir, "static_model.ply"), result.static_model,
                  "dynamap-label static model: centres of the static voxels (world frame, m); "
                  "probability = hit ratio (frames occupied / frames seen)");
  }
}

}  // namespace dynamap::tools::label
