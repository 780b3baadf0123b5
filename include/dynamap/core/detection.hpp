// Detection: one obstacle proposal of a frame, as produced by the U-map detector and refined
// against the occupancy map; the tracker's input.
#pragma once

#include "dynamap/core/types.hpp"

namespace dynamap {

struct Detection {
  Box3 box;                ///< axis-aligned box in the map frame (refined when `refined`)
  Box3 raw_box;            ///< the detector's box before refinement (map frame)
  ImageBox image_box;      ///< where it was seen in the depth image (for the "fully in view" test)
  float near_depth = 0.f;  ///< camera-frame depth of the nearest surface (metres)
  bool refined = false;    ///< true when `box` was tightened to occupied voxels
  /// Share of this frame's surface cells in the raw box that the camera had observed free for a
  /// while (EverFreeGrid; 0 when not computed): the obstacle moved into empty space.
  float ever_free = 0.f;
  /// Share of the occupied voxels in the raw box that the map had held occupied for at least
  /// MapRefinerConfig::static_frames (MapRefiner; 0 when not computed): a surface seen for a
  /// long time, not a body that just arrived. A moving camera sliding its view along a static
  /// box makes the detection move; its voxels stay old.
  float static_share = 0.f;
};

}  // namespace dynamap
