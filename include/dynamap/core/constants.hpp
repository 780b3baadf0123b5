// Compile-time capacities and platform-neutral constants shared by all stages.
// Every per-frame array in dynamap is sized from these, so the footprint is known at build time.
#pragma once

#include <cstddef>

namespace dynamap {

/// Cache line size used to separate data written by different threads. 64 covers x86-64 and
/// Carmel; we do not use std::hardware_destructive_interference_size (GCC says 256 on aarch64).
inline constexpr std::size_t kCacheLine = 64;

/// Largest depth image accepted (640x480 RGB-D at 30 Hz is the design point).
inline constexpr int kMaxImageWidth = 640;
inline constexpr int kMaxImageHeight = 480;

/// Maximum raw detections per frame from the U-map detector.
inline constexpr std::size_t kMaxDetections = 32;
/// Maximum simultaneously tracked obstacles.
inline constexpr std::size_t kMaxTracks = 32;
/// Longest box history per track (f frames: the tracker keeps them, the cleaner walks them).
inline constexpr std::size_t kMaxBoxHistory = 64;
/// Maximum number of candidate paths in the prediction library.
inline constexpr std::size_t kMaxPaths = 16;
/// Maximum samples along one predicted path.
inline constexpr std::size_t kMaxPathSamples = 32;

}  // namespace dynamap
