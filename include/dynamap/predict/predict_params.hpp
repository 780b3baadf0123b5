// Parameter tables of the predict stage: Path library, clearance sweep, Markov predictor, depth
// check and far-field layer. One row per config field (core/parameter.hpp): member path, unit,
// valid range, tier, help; the default is the struct's member initialiser. The configs' validate()
// checks these ranges; the pipeline assembles the tables into PipelineConfig's
// (src/pipeline/parameters.cpp).
#pragma once

#include "dynamap/core/parameter.hpp"
#include "dynamap/predict/far_field_layer.hpp"
#include "dynamap/predict/markov_predictor.hpp"
#include "dynamap/predict/path_library.hpp"
#include "dynamap/predict/prediction.hpp"

namespace dynamap::params {
using namespace param_rows;  // NOLINT(google-build-using-namespace): U, C, X, kOpen, ...

/// Largest predictor.paths.max_heading_change: pi, as a float (rad).
inline constexpr float kMaxHeadingChange = 3.14159265358979f;

/// The parameters of PathLibraryConfig, one row per field (PipelineConfig prefix
/// "predictor.paths.").
inline constexpr Param<PathLibraryConfig> kPathLibrary[] = {
    // clang-format off
    {DYNAMAP_PARAM(PathLibraryConfig, num_paths), C, "", 1, kMaxPaths, kClosed, kClosed, "l: paths in the library"},
    {DYNAMAP_PARAM(PathLibraryConfig, max_heading_change), X, "rad", 0, kMaxHeadingChange, kClosed, kClosed, "heading change of the outermost paths"},
    {DYNAMAP_PARAM(PathLibraryConfig, turn_curvature), X, "1/m", 0, kInf, kOpen, kOpen, "curvature while turning"},
    {DYNAMAP_PARAM(PathLibraryConfig, horizon_distance), U, "m", 0, kInf, kOpen, kOpen, "prediction horizon: travel at the current speed"},
    {DYNAMAP_PARAM(PathLibraryConfig, slow_speed), X, "m/s", 0, kInf, kClosed, kOpen, "slower obstacles are predicted for slow_horizon_time instead"},
    {DYNAMAP_PARAM(PathLibraryConfig, slow_horizon_time), X, "s", 0, kInf, kOpen, kOpen, "horizon of slow obstacles"},
    {DYNAMAP_PARAM(PathLibraryConfig, sample_interval), X, "s", 0, kInf, kOpen, kOpen, "upper bound on the time between path samples"},
    // clang-format on
};
static_assert(paths_unique(kPathLibrary));

/// The parameters of ClearanceConfig, one row per field (PipelineConfig prefix
/// "predictor.clearance.").
inline constexpr Param<ClearanceConfig> kClearance[] = {
    // clang-format off
    {DYNAMAP_PARAM(ClearanceConfig, line_spacing), X, "m", 0, kInf, kOpen, kOpen, "spacing of the swept lines across the footprint"},
    {DYNAMAP_PARAM(ClearanceConfig, max_lines), C, "", 1, kMaxClearanceLines, kClosed, kClosed, "work cap: swept lines per path"},
    {DYNAMAP_PARAM(ClearanceConfig, height_levels), C, "", 1, kMaxHeightLevels, kClosed, kClosed, "heights swept per line"},
    {DYNAMAP_PARAM(ClearanceConfig, chord_tolerance), X, "m", 0, kInf, kClosed, kOpen, "a merged chord may leave the path by this much"},
    {DYNAMAP_PARAM(ClearanceConfig, ground_clearance), X, "m", 0, kInf, kClosed, kOpen, "height above the box bottom not checked (floor voxels)"},
    {DYNAMAP_PARAM(ClearanceConfig, self_margin), X, "m", 0, kInf, kClosed, kOpen, "space around the obstacle's own body not checked"},
    {DYNAMAP_PARAM(ClearanceConfig, self_range_margin), X, "m/m^2", 0, kInf, kClosed, kOpen, "added to self_margin per squared m of the obstacle's range"},
    // clang-format on
};
static_assert(paths_unique(kClearance));

/// The parameters of MarkovPredictorConfig, one row per field (PipelineConfig prefix "predictor.").
inline constexpr Param<MarkovPredictorConfig> kMarkovPredictor[] = {
    // clang-format off
    {DYNAMAP_PARAM(MarkovPredictorConfig, sigma_init), X, "rad", 0, kInf, kOpen, kOpen, "spread of the initial belief around the straight path"},
    {DYNAMAP_PARAM(MarkovPredictorConfig, sigma_trans), X, "rad", 0, kInf, kOpen, kOpen, "spread of each transition row around its diagonal"},
    {DYNAMAP_PARAM(MarkovPredictorConfig, beta), X, "1/m", 0, kInf, kClosed, kOpen, "P_env = softmax(beta x free distance); 0 ignores the map"},
    {DYNAMAP_PARAM(MarkovPredictorConfig, choose_free), X, "", 0, 1, kClosed, kClosed, "output the likeliest path that is free in the map"},
    {DYNAMAP_PARAM(MarkovPredictorConfig, straight_when_free), X, "", 0, 1, kClosed, kClosed, "output the straight path whenever it is free and no path is better supported"},
    {DYNAMAP_PARAM(MarkovPredictorConfig, turn_back_curvature), X, "1/m", 0, kInf, kClosed, kOpen, "with no path free, paths turning back are tried again at this curvature (0: off)"},
    // clang-format on
};
static_assert(paths_unique(kMarkovPredictor));

/// The parameters of FarFieldConfig, one row per field (PipelineConfig prefix "far_field.").
inline constexpr Param<FarFieldConfig> kFarField[] = {
    // clang-format off
    {DYNAMAP_PARAM(FarFieldConfig, enabled), X, "", 0, 1, kClosed, kClosed, "update the far-field layer and let the predictor use it"},
    {DYNAMAP_PARAM(FarFieldConfig, cell_size), X, "m", 0.05, 1, kClosed, kClosed, "grid cell and range bin"},
    {DYNAMAP_PARAM(FarFieldConfig, max_range), U, "m", 0, 25, kOpen, kClosed, "horizontal range of the pixels used (the camera's useful range)"},
    {DYNAMAP_PARAM(FarFieldConfig, hit_min_range), X, "m", 0, kInf, kClosed, kOpen, "nearer surfaces are the map's"},
    {DYNAMAP_PARAM(FarFieldConfig, min_height), X, "m", -kInf, kInf, kOpen, kOpen, "above ground_height: lower pixels are floor"},
    {DYNAMAP_PARAM(FarFieldConfig, max_height), X, "m", -kInf, kInf, kOpen, kOpen, "above ground_height: higher pixels are ceiling"},
    {DYNAMAP_PARAM(FarFieldConfig, wall_height), X, "m", -kInf, kInf, kOpen, kOpen, "above ground_height a surface must reach to be a wall"},
    {DYNAMAP_PARAM(FarFieldConfig, noise_margin), X, "m", 0, kInf, kClosed, kOpen, "constant part of the range noise sigma(d)"},
    {DYNAMAP_PARAM(FarFieldConfig, noise_quadratic), X, "1/m", 0, kInf, kClosed, kOpen, "quadratic part of the range noise sigma(d)"},
    {DYNAMAP_PARAM(FarFieldConfig, pixel_stride), C, "px", 1, 16, kClosed, kClosed, "sampled columns and rows"},
    {DYNAMAP_PARAM(FarFieldConfig, min_pixels), X, "px", 1, kInf, kClosed, kOpen, "pixels in a column's noise window to accept a surface"},
    {DYNAMAP_PARAM(FarFieldConfig, min_rise_sigmas), X, "", 0, kInf, kClosed, kOpen, "height a surface's returns must span, in sigmas of the noise's vertical share: flatter is a ceiling seen edge-on"},
    {DYNAMAP_PARAM(FarFieldConfig, hit_evidence), X, "", 1, 100, kClosed, kClosed, "added per frame a cell is hit"},
    {DYNAMAP_PARAM(FarFieldConfig, free_evidence), X, "", 0, 100, kClosed, kClosed, "removed per frame a ray passes a cell"},
    {DYNAMAP_PARAM(FarFieldConfig, max_evidence), X, "", 1, 127, kClosed, kClosed, "evidence clamp"},
    {DYNAMAP_PARAM(FarFieldConfig, memory_frames), X, "frames", 1, kInf, kClosed, kOpen, "a wall is forgotten this many frames after its last hit"},
    {DYNAMAP_PARAM(FarFieldConfig, low_frames), X, "frames", 0, 255, kClosed, kClosed, "frames a surface lower than wall_height must stay in one cell to be a wall (0: never)"},
    // clang-format on
};
static_assert(paths_unique(kFarField));

/// Relations between FarFieldConfig fields, checked by validate(FarFieldConfig) after the ranges
/// and named by the pipeline's validate().
inline constexpr Relation<FarFieldConfig> kFarFieldRelations[] = {
    {"max_range", "must be > far_field.hit_min_range",
     [](const FarFieldConfig& c) noexcept { return c.max_range > c.hit_min_range; }},
    // Every range bin of a column must fit, and the grid must hold the range on every side.
    {"max_range",
     "must be <= (kFarFieldCellsPerSide / 2 - 1) x far_field.cell_size (12.6 m at 0.2 m)",
     [](const FarFieldConfig& c) noexcept {
       return c.max_range / c.cell_size <= static_cast<float>(kFarFieldMaxBins) &&
              2.f * c.max_range / c.cell_size <= static_cast<float>(kFarFieldCellsPerSide) - 2.f;
     }},
    {"max_height", "must be > far_field.min_height",
     [](const FarFieldConfig& c) noexcept { return c.max_height > c.min_height; }},
    {"wall_height", "must be in [far_field.min_height, far_field.max_height]",
     [](const FarFieldConfig& c) noexcept {
       return c.wall_height >= c.min_height && c.wall_height <= c.max_height;
     }},
    {"max_evidence", "must be >= far_field.hit_evidence",
     [](const FarFieldConfig& c) noexcept { return c.max_evidence >= c.hit_evidence; }},
};

}  // namespace dynamap::params
