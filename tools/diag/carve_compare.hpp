// Accuracy cost of early-stop free-space carving (OccupancyMapConfig::free_ray_early_stop):
// integrates the same frames into an exact map (free_ray_early_stop = 0) and into one map per
// early-stop count, and compares what each frame updated and what the maps hold at the end.
// Header-only and host-only (heap and std containers are fine here): used by
// dynamap-occ-diag (simulated sequences) and by bench_occupancy_map --accuracy (bench scene).
//
// A frame's update set (which voxels get a hit or a miss) does not depend on the map's
// contents, only on the frame (stamps are per frame), as long as no cap or full pool drops
// work (reported when it does); so maps run side by side can be compared frame by frame.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "dynamap/map/occupancy_map.hpp"

namespace dynamap::diag {

class CarveComparison {
 public:
  static constexpr std::size_t kRangeBins = 6;
  static constexpr double kRangeBin = 1.0;  // m, camera to voxel centre; the last bin is open

  /// `stops`: early-stop counts to compare with the exact mode; `recover_frames`: how many
  /// later frames a skipped miss may take to be carried out after all.
  CarveComparison(const OccupancyMapConfig& base, const std::vector<int>& stops,
                  int recover_frames = 3)
      : recover_frames_(static_cast<std::size_t>(recover_frames)) {
    OccupancyMapConfig exact = base;
    exact.free_ray_early_stop = 0;
    exact_ = make(exact);
    for (int n : stops) {
      Mode m;
      m.stop = n;
      OccupancyMapConfig c = base;
      c.free_ray_early_stop = n;
      m.map = make(c);
      modes_.push_back(std::move(m));
    }
  }

  bool add_frame(const DepthView& depth, const CameraIntrinsics& cam, const Pose& pose,
                 Stamp stamp) {
    if (!ok(exact_->integrate(depth, cam, pose, stamp))) return false;
    ++frames_;
    const IntegrationStats& es = exact_->last_stats();
    exact_visits_ += static_cast<double>(es.voxel_visits);
    exact_dropped_ += es.updates_dropped + es.rays_dropped;
    std::unordered_set<std::uint64_t> ex_miss, ex_hit;
    exact_->for_each_updated_last_frame(
        [&](std::uint64_t k, bool hit) { (hit ? ex_hit : ex_miss).insert(k); });
    exact_misses_ += ex_miss.size();
    exact_union_.insert(ex_miss.begin(), ex_miss.end());
    touched_.insert(ex_miss.begin(), ex_miss.end());
    touched_.insert(ex_hit.begin(), ex_hit.end());
    for (Mode& m : modes_) {
      // The exact walk carves again a voxel this mode skipped earlier: it was not a one-off.
      for (std::uint64_t k : ex_miss) {
        const auto p = m.pending.find(k);
        if (p != m.pending.end()) p->second.exact_again = true;
      }
      if (!ok(m.map->integrate(depth, cam, pose, stamp))) return false;
      const IntegrationStats& st = m.map->last_stats();
      m.visits += static_cast<double>(st.voxel_visits);
      m.stopped += static_cast<double>(st.rays_stopped_early);
      m.rays += static_cast<double>(st.rays);
      m.dropped += st.updates_dropped + st.rays_dropped;
      std::size_t covered = 0, shared_hits = 0;
      std::unordered_set<std::uint64_t> es_miss;
      m.map->for_each_updated_last_frame([&](std::uint64_t k, bool hit) {
        touched_.insert(k);
        if (hit) {
          if (ex_hit.count(k) == 0) {
            ++m.hit_mismatch;  // a hit the exact map did not get
          } else {
            ++shared_hits;
          }
          return;
        }
        es_miss.insert(k);
        m.union_set.insert(k);
        if (ex_miss.count(k) != 0) {
          ++covered;
        } else {
          ++m.extra;
        }
        const auto p = m.pending.find(k);  // skipped in an earlier frame, carried out now
        if (p != m.pending.end()) {
          ++m.recovered;
          m.pending.erase(p);
        }
      });
      m.hit_mismatch += ex_hit.size() - shared_hits;  // hits this map did not get
      m.covered += covered;
      m.frame_share.push_back(ex_miss.empty() ? 1.0
                                              : static_cast<double>(covered) /
                                                    static_cast<double>(ex_miss.size()));
      for (auto it = m.pending.begin(); it != m.pending.end();) {
        if (it->second.deadline < frames_) {
          ++(it->second.exact_again ? m.lost : m.one_off);
          it = m.pending.erase(it);
        } else {
          ++it;
        }
      }
      for (std::uint64_t k : ex_miss) {
        const double range = (exact_->center_of(k) - pose.translation).norm();
        const auto bin = std::min<std::size_t>(kRangeBins - 1, static_cast<std::size_t>(range));
        ++m.exact_by_range[bin];
        if (es_miss.count(k) != 0) continue;
        ++m.skipped_by_range[bin];
        m.pending[k] = Pending{frames_ + recover_frames_, false};
      }
    }
    return true;
  }

  void print(std::FILE* out, const char* scene) const {
    for (const Mode& m : modes_) {
      // Final states over every voxel either map ever updated (any other is unknown in both).
      std::size_t ex_occ = 0, occ = 0, occ_differ = 0, ex_free = 0, fr = 0, free_lost = 0;
      std::size_t log_odds_differ = 0;
      for (std::uint64_t k : touched_) {
        const Occupancy a = exact_->state(k), b = m.map->state(k);
        ex_occ += a == Occupancy::kOccupied;
        occ += b == Occupancy::kOccupied;
        occ_differ += (a == Occupancy::kOccupied) != (b == Occupancy::kOccupied);
        ex_free += a == Occupancy::kFree;
        fr += b == Occupancy::kFree;
        free_lost += a == Occupancy::kFree && b != Occupancy::kFree;
        const Eigen::Vector3f c = exact_->center_of(k);
        // Half a miss (0.31) or more apart: at least one update differs.
        log_odds_differ += std::fabs(exact_->log_odds(c) - m.map->log_odds(c)) > 0.3f;
      }
      std::size_t union_covered = 0;
      for (std::uint64_t k : exact_union_) union_covered += m.union_set.count(k);
      std::vector<double> shares = m.frame_share;
      std::sort(shares.begin(), shares.end());
      const double f = static_cast<double>(std::max<std::size_t>(frames_, 1));
      std::fprintf(out, "%s N=%d (%zu frames)\n", scene, m.stop, frames_);
      std::fprintf(out,
                   "  exact misses carried out per frame: mean %.3f %%, median %.3f %%, "
                   "min %.3f %%; extra misses %.1f/frame; hits differing %zu\n",
                   100.0 * static_cast<double>(m.covered) /
                       static_cast<double>(std::max<std::size_t>(exact_misses_, 1)),
                   shares.empty() ? 100.0 : 100.0 * shares[shares.size() / 2],
                   shares.empty() ? 100.0 : 100.0 * shares.front(),
                   static_cast<double>(m.extra) / f, m.hit_mismatch);
      const std::size_t decided = m.recovered + m.lost + m.one_off;
      std::fprintf(out,
                   "  skipped misses: %zu decided; carried out within %zu frames %.1f %%, "
                   "never (exact walk carved them again) %.1f %%, never (exact walk did not "
                   "either) %.1f %%\n",
                   decided, recover_frames_,
                   100.0 * static_cast<double>(m.recovered) / std::max<double>(1, decided),
                   100.0 * static_cast<double>(m.lost) / std::max<double>(1, decided),
                   100.0 * static_cast<double>(m.one_off) / std::max<double>(1, decided));
      std::fprintf(out, "  skipped share of exact misses by range (1 m bins, last open):");
      for (std::size_t b = 0; b < kRangeBins; ++b) {
        std::fprintf(out, " %.2f%%",
                     100.0 * static_cast<double>(m.skipped_by_range[b]) /
                         std::max<double>(1, static_cast<double>(m.exact_by_range[b])));
      }
      std::fprintf(out, "\n");
      std::fprintf(out,
                   "  whole sequence: voxels ever missed %.4f %% of exact's; final occupied "
                   "%zu vs %zu, %zu differ; final free %zu vs %zu, %zu of exact's not free; "
                   "log-odds differ > 0.3 on %zu of %zu voxels\n",
                   100.0 * static_cast<double>(union_covered) /
                       std::max<double>(1, static_cast<double>(exact_union_.size())),
                   ex_occ, occ, occ_differ, ex_free, fr, free_lost, log_odds_differ,
                   touched_.size());
      std::fprintf(out,
                   "  work per frame: visits %.0f exact, %.0f here (%.2fx fewer); %.0f of %.0f "
                   "rays stopped early\n",
                   exact_visits_ / f, m.visits / f, exact_visits_ / std::max(1.0, m.visits),
                   m.stopped / f, m.rays / f);
      if (exact_dropped_ != 0 || m.dropped != 0) {
        std::fprintf(out,
                     "  (work dropped by caps or a full pool: exact %zu, here %zu; the "
                     "frame-by-frame comparison assumes none)\n",
                     exact_dropped_, m.dropped);
      }
    }
  }

 private:
  struct Pending {
    std::size_t deadline = 0;  // last frame in which carrying it out counts as recovered
    bool exact_again = false;
  };
  struct Mode {
    int stop = 0;
    std::unique_ptr<OccupancyMap> map;
    std::size_t covered = 0, extra = 0, hit_mismatch = 0, recovered = 0, lost = 0, one_off = 0;
    std::size_t dropped = 0;
    double visits = 0, stopped = 0, rays = 0;
    std::vector<double> frame_share;
    std::array<std::size_t, kRangeBins> exact_by_range{}, skipped_by_range{};
    std::unordered_set<std::uint64_t> union_set;
    std::unordered_map<std::uint64_t, Pending> pending;
  };

  static std::unique_ptr<OccupancyMap> make(const OccupancyMapConfig& c) {
    auto m = std::make_unique<OccupancyMap>();
    if (!ok(m->init(c))) std::abort();
    return m;
  }

  std::size_t recover_frames_;
  std::unique_ptr<OccupancyMap> exact_;
  std::vector<Mode> modes_;
  std::size_t frames_ = 0, exact_misses_ = 0, exact_dropped_ = 0;
  double exact_visits_ = 0;
  std::unordered_set<std::uint64_t> exact_union_;
  std::unordered_set<std::uint64_t> touched_;  // updated at least once by any of the maps
};

}  // namespace dynamap::diag
