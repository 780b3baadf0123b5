// Parameter tables of the detect stage: U-map detector and detection refiner (fragment joining).
// One row per config field (core/parameter.hpp): member path, unit, valid range, tier, help; the
// default is the struct's member initialiser. The configs' validate() checks these ranges; the
// pipeline assembles the tables into PipelineConfig's (src/pipeline/parameters.cpp).
#pragma once

#include "dynamap/core/parameter.hpp"
#include "dynamap/detect/detection_refiner.hpp"
#include "dynamap/detect/umap_detector.hpp"

namespace dynamap::params {
using namespace param_rows;  // NOLINT(google-build-using-namespace): U, C, X, kOpen, ...

/// The parameters of UMapDetectorConfig, one row per field (PipelineConfig prefix "detector.").
inline constexpr Param<UMapDetectorConfig> kUMapDetector[] = {
    // clang-format off
    {DYNAMAP_PARAM(UMapDetectorConfig, bins), X, "", 1, kMaxUMapBins, kClosed, kClosed, "U-map depth bins over [d_min, d_max]"},
    {DYNAMAP_PARAM(UMapDetectorConfig, d_min), X, "m", 0, kInf, kClosed, kOpen, "nearer depths are not counted in the U-map"},
    {DYNAMAP_PARAM(UMapDetectorConfig, d_max), U, "m", 0, kInf, kOpen, kOpen, "detection range: farther depths are not counted"},
    {DYNAMAP_PARAM(UMapDetectorConfig, smoothing_radius), X, "bins", 0, kMaxUMapSmoothingRadius, kClosed, kClosed, "U-map cells are tested on the sum over +-r bins (0: off)"},
    {DYNAMAP_PARAM(UMapDetectorConfig, count_threshold), X, "px", 1, 65535, kClosed, kClosed, "pixels a U-map cell needs to be a point"},
    {DYNAMAP_PARAM(UMapDetectorConfig, min_point_height), X, "m", 0, kInf, kClosed, kOpen, "surface height a U-map cell must show to be a point"},
    {DYNAMAP_PARAM(UMapDetectorConfig, min_segment_length), X, "columns", 1, kMaxImageWidth, kClosed, kClosed, "shorter runs of points are ignored"},
    {DYNAMAP_PARAM(UMapDetectorConfig, min_area), X, "cells", 1, kInf, kClosed, kOpen, "smaller point groups are dropped"},
    {DYNAMAP_PARAM(UMapDetectorConfig, band_factor), X, "", 1, 10, kClosed, kClosed, "depth band [near, near + factor x extent] of a group's pixels"},
    {DYNAMAP_PARAM(UMapDetectorConfig, max_candidates), C, "", 1, kInf, kClosed, kOpen, "work cap: height searches per frame, nearest groups first"},
    {DYNAMAP_PARAM(UMapDetectorConfig, max_detections), C, "", 1, kMaxDetections, kClosed, kClosed, "detections per frame"},
    {DYNAMAP_PARAM(UMapDetectorConfig, row_fill_fraction), X, "", 0, 1, kClosed, kClosed, "share of a group's columns a row needs to count in the height search"},
    {DYNAMAP_PARAM(UMapDetectorConfig, max_row_gap), X, "rows", 0, kMaxImageHeight, kClosed, kClosed, "gaps bridged in the height search"},
    {DYNAMAP_PARAM(UMapDetectorConfig, min_run_rows), X, "rows", 1, kMaxImageHeight, kClosed, kClosed, "shortest vertical run that is an object"},
    {DYNAMAP_PARAM(UMapDetectorConfig, max_width_fraction), X, "", 0, 1, kOpen, kClosed, "groups this wide a share of the image are background"},
    {DYNAMAP_PARAM(UMapDetectorConfig, max_width), X, "m", 0, kInf, kOpen, kOpen, "wider groups are background"},
    {DYNAMAP_PARAM(UMapDetectorConfig, max_height), X, "m", 0, kInf, kOpen, kOpen, "taller groups are background"},
    {DYNAMAP_PARAM(UMapDetectorConfig, max_depth_extent), X, "m", 0, kInf, kOpen, kOpen, "groups deeper than this are background (a wall at a grazing angle)"},
    {DYNAMAP_PARAM(UMapDetectorConfig, use_fast_histogram), X, "", 0, 1, kClosed, kClosed, "NEON/vectorised U-map histogram (false: scalar reference)"},
    {DYNAMAP_PARAM(UMapDetectorConfig, use_fast_measure), X, "", 0, 1, kClosed, kClosed, "vectorisable height search and box sums (false: per-pixel reference loops)"},
    // clang-format on
};
static_assert(paths_unique(kUMapDetector));

/// Relations between UMapDetectorConfig fields, checked by UMapDetector::init() after the ranges
/// and named by the pipeline's validate().
inline constexpr Relation<UMapDetectorConfig> kUMapDetectorRelations[] = {
    {"d_max", "must be > detector.d_min",
     [](const UMapDetectorConfig& c) noexcept { return c.d_max > c.d_min; }},
};

/// The parameters of DetectionRefinerConfig, one row per field (PipelineConfig prefix
/// "fragments.").
inline constexpr Param<DetectionRefinerConfig> kDetectionRefiner[] = {
    // clang-format off
    {DYNAMAP_PARAM(DetectionRefinerConfig, join_fragments), X, "", 0, 1, kClosed, kClosed, "join the detector's fragments of one obstacle"},
    {DYNAMAP_PARAM(DetectionRefinerConfig, max_gap), X, "m", -kInf, 1, kOpen, kClosed, "largest top-view gap between joined boxes (negative: must overlap)"},
    {DYNAMAP_PARAM(DetectionRefinerConfig, max_footprint), X, "m", 0, 5, kOpen, kClosed, "largest horizontal side of a joined box"},
    {DYNAMAP_PARAM(DetectionRefinerConfig, split_groups), X, "", 0, 1, kClosed, kClosed, "split detections that hold several people (side by side, one behind the other)"},
    {DYNAMAP_PARAM(DetectionRefinerConfig, split_width), X, "m", 0.1, 5, kClosed, kClosed, "only detections wider than this across the view are split side by side"},
    {DYNAMAP_PARAM(DetectionRefinerConfig, split_min_part), X, "m", 0.05, 2, kClosed, kClosed, "each side of a split across the view is at least this wide"},
    {DYNAMAP_PARAM(DetectionRefinerConfig, split_dip), X, "", 0, 1, kClosed, kClosed, "split where the pixels per column fall to this share of the lower peak beside"},
    {DYNAMAP_PARAM(DetectionRefinerConfig, split_depth_gap), X, "m", 0.1, 2, kClosed, kClosed, "an empty stretch of depth this long along the ray splits near from far"},
    // clang-format on
};
static_assert(paths_unique(kDetectionRefiner));

}  // namespace dynamap::params
