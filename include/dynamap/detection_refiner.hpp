// Detection refiner: joins the fragments of one obstacle that the U-map detector reports as
// separate detections. On real depth a person comes out in pieces (a head above a hole in the
// depth, the two halves of a torso split by flying pixels at an arm): pieces whose top-view boxes
// touch and whose joined footprint is still person-sized are one detection. Runs on the
// detector's output, before map refinement; no heap, bounded work (kMaxDetections^2 pairs).
#pragma once

#include <cstddef>

#include "dynamap/detection.hpp"
#include "dynamap/fixed_vector.hpp"
#include "dynamap/status.hpp"
#include "dynamap/umap_detector.hpp"

namespace dynamap {

struct DetectionRefinerConfig {
  bool join_fragments = true;
  /// Largest top-view gap (m) between two boxes that are joined (negative: they must overlap).
  float max_gap = 0.1f;
  /// Largest horizontal side (m) of the joined box: more is two obstacles side by side.
  float max_footprint = 0.8f;

  Status validate() const noexcept;
};

class DetectionRefiner {
 public:
  [[nodiscard]] Status init(const DetectionRefinerConfig& config) noexcept;
  /// Joins fragments in place (the list keeps its nearest-first order of first members).
  /// Returns the number of joins made.
  std::size_t join(DetectionList& dets) const noexcept;
  const DetectionRefinerConfig& config() const noexcept { return config_; }

 private:
  bool joinable(const Detection& a, const Detection& b) const noexcept;
  DetectionRefinerConfig config_{};
};

}  // namespace dynamap
