// The replay as an MCAP file for Foxglove (dynamap-replay --mcap FILE): per frame the camera pose
// (foxglove.FrameTransform world -> camera), the depth image (foxglove.RawImage, 16UC1), the
// tracked obstacles (foxglove.SceneUpdate: boxes coloured by label, ids, velocity arrows), the
// chosen and linear predicted paths (foxglove.SceneUpdate), every N frames the map's occupied
// voxels around the camera (foxglove.PointCloud) and, with a reference, its people
// (foxglove.SceneUpdate). JSON messages with the schemas' JSON Schema in the file, zstd chunks:
// the file needs nothing else. Layout: docs/foxglove_layout.json.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "common/mcap_writer.hpp"
#include "common/obstacles.hpp"
#include "common/png_io.hpp"
#include "common/replay_hooks.hpp"
#include "common/sequence.hpp"
#include "dynamap/pipeline/pipeline.hpp"

namespace dynamap::tools {

class FoxgloveOutput {
 public:
  /// `reference`: people to draw (obstacles.txt records; may be empty).
  FoxgloveOutput(const std::string& path, const CameraModel& camera, long map_every,
                 std::vector<ObstacleRecord> reference);
  void frame(const SequenceFrame& frame, std::uint64_t stamp_ns, const Image16& depth,
             const Pose& camera, const Pipeline& pipeline, const FrameOutput& out);
  void close() { writer_.close(); }

 private:
  void write(std::uint16_t channel, std::uint64_t t, const std::string& json);
  void write_tracks(std::uint64_t t, const FrameOutput& out);
  void write_paths(std::uint64_t t, const Pipeline& pipeline, const FrameOutput& out);
  void write_map(std::uint64_t t, const Pipeline& pipeline, const Pose& camera);
  void write_reference(std::uint64_t t, double stamp);

  mcap::Writer writer_;
  CameraModel camera_;
  long map_every_;
  std::vector<ObstacleRecord> reference_;
  std::uint16_t pose_ = 0, image_ = 0, tracks_ = 0, paths_ = 0, map_ = 0, people_ = 0;
  std::size_t frames_ = 0;
};

/// The --mcap output of a replay, or null without --mcap. `truth`: SEQ/obstacles.txt (drawn
/// when --reference is not given). Throws ToolError.
std::unique_ptr<FoxgloveOutput> make_foxglove_output(const ReplayExtras& extras,
                                                     const Sequence& seq,
                                                     const std::vector<ObstacleRecord>& truth);

/// The JSON Schema of a foxglove.* message this writer uses ("" for another name).
std::string foxglove_schema(const std::string& name);

}  // namespace dynamap::tools
