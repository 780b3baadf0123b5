// Deliberately worst-case depth frames: inputs that drive each stage to its configured work cap,
// for tests (work counters hit their caps and stop there) and for worst-case timing benchmarks.
// They write into a caller-provided buffer; nothing is allocated. Not part of the flight
// library: link dynamap::testing (installed with it) for timing-budget tests of your own.
#pragma once

#include <cstddef>
#include <cstdint>

#include "dynamap/core/types.hpp"
#include "dynamap/pipeline/pipeline_config.hpp"

namespace dynamap {

enum class WorstCase : std::uint8_t {
  kMaxRange,  ///< every pixel valid just inside the maximum range: most rays, longest rays
  kClutter,   ///< `obstacles` narrow bars at alternating depths over a max-range background:
              ///< most detections and tracks, plus long rays everywhere else
  kApproach,  ///< `obstacles` bars over a max-range background that come 3 cm closer every
              ///< phase (from 4 m to 1.2 m, then again): tracks that live, move and are
              ///< predicted, so the predictors do their most work too
};

/// Fills `pixels` (cam.width x cam.height, tightly packed) with the worst case `kind` and
/// returns a view of it. `max_depth_m` is the occupancy map's max range; `obstacles` is used by
/// kClutter and kApproach (capped so every bar stays at least kMinBarPixels wide, what the
/// default detector needs to see a bar); `phase` is the frame index of a sequence.
inline constexpr int kMinBarPixels = 21;
DepthView make_worst_case_depth(WorstCase kind, const CameraIntrinsics& cam, float max_depth_m,
                                std::size_t obstacles, std::uint16_t* pixels,
                                unsigned phase = 0) noexcept;

/// The defaults with every per-frame work cap at the largest value validation accepts (rays,
/// voxel visits, detections, refiner and cleaner voxels): the configuration whose worst frame is
/// the longest the pipeline can be asked to do.
PipelineConfig largest_work_caps() noexcept;

}  // namespace dynamap
