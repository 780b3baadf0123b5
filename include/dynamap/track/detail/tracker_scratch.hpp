// The tracker's per-update scratch: measurements, candidate pairs and their flags. Installed
// only because Tracker (and the Pipeline that holds it) is inline; not a stable API.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

#include <Eigen/Core>

#include "dynamap/core/constants.hpp"

namespace dynamap::detail {

/// A detection after the tracker's bias correction.
struct TrackMeasurement {
  Eigen::Vector3f center;
  Eigen::Vector3f size;      // estimated full size
  Eigen::Vector3f own_size;  // full size estimated from this detection alone (not the fixed one)
  Eigen::Vector3f raw_size;  // the detection box's own size
  Eigen::Vector4f edges;     // the detection box's top-view min x, min y, max x, max y
  bool in_view;
  bool near_enough;  // near enough for size fixing
  bool on_static;    // on long-occupied voxels (static share above max_static_share)
  // A side of its image box is the object's own (not the border, not an occluder); set for
  // every detection of the frame by Tracker::mark_own_edges.
  bool own_edge = true;
};
/// A candidate (detection, track) association.
struct TrackPair {
  float distance;
  std::uint8_t det;
  std::uint8_t slot;
};
/// One Tracker::update()'s working memory, held by the tracker (no stack arrays of this size).
struct TrackerScratch {
  std::array<TrackMeasurement, kMaxDetections> meas;
  std::array<TrackPair, kMaxDetections * kMaxTracks> pairs;
  std::size_t pair_count = 0;
  std::array<bool, kMaxDetections> det_used{};
  std::array<bool, kMaxTracks> track_used{};
};

}  // namespace dynamap::detail
