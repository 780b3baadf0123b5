// Tracking results drawn on the depth images (dynamap-overlay, docs/tools.md): colour-mapped
// depth, the detector's image boxes, every track's world box projected into the image, the
// reference (ground-truth) people, and what went wrong at a glance: reference people no dynamic
// track is near ("MISSED") and dynamic tracks near no reference obstacle ("FALSE DYN").
// Plain data in, PNG out, like render_top_view(); run_overlay() is the whole tool.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "common/obstacles.hpp"
#include "common/png_io.hpp"
#include "common/results.hpp"
#include "common/sequence.hpp"

namespace dynamap::tools::overlay {

/// One row of detections.csv: stamp,index,x,y,z,sx,sy,sz,u0,v0,u1,v1,refined — the world box
/// (centre, size) and the detector's image box [u0,u1] x [v0,v1] in pixels, inclusive.
struct DetectionRow {
  double stamp = 0.0;
  std::string stamp_text;
  int index = 0;
  Eigen::Vector3d center = Eigen::Vector3d::Zero();
  Eigen::Vector3d size = Eigen::Vector3d::Zero();
  double u0 = 0, v0 = 0, u1 = 0, v1 = 0;
  bool refined = false;
};

/// Reads detections.csv; columns are found by header name and extra ones ignored. stamp, u0, v0,
/// u1 and v1 are required, the others default to zero. Throws ToolError ("file:line: ...").
std::vector<DetectionRow> read_detections_csv(const std::string& path);

/// An image rectangle in pixel coordinates (continuous: pixel u covers [u, u+1)).
struct PixelRect {
  double u0 = 0, v0 = 0, u1 = 0, v1 = 0;
};

/// Projects a world-frame axis-aligned box (centre, full size) into the image of a camera at
/// T_world_camera: the 2-D bounding rectangle of the part of the box in front of the camera
/// (camera z >= min_z; the 12 edges are cut at that plane). False when no part is in front, or
/// the rectangle misses the image entirely. The rectangle is not cut to the image.
bool project_box(const CameraModel& camera, const PoseD& pose, const Eigen::Vector3d& center,
                 const Eigen::Vector3d& size, PixelRect* out, double min_z = 0.1);

/// Projects the horizontal motion of a world point over `seconds`: `from` is the image point of
/// `center`, `to` that of center + seconds * (vx, vy, 0). False when either point is not in
/// front of the camera (camera z < min_z). Used to draw velocity arrows.
bool project_motion(const CameraModel& camera, const PoseD& pose, const Eigen::Vector3d& center,
                    const Eigen::Vector3d& velocity, double seconds, Eigen::Vector2d* from,
                    Eigen::Vector2d* to, double min_z = 0.1);

/// The depth colour map: near = warm (red, orange, yellow), far = cool (cyan, blue), on a
/// logarithmic scale between near_m and far_m (clamped outside); 0 m = no measurement, dark grey.
struct Rgb8 {
  std::uint8_t r = 0, g = 0, b = 0;
};
Rgb8 depth_colour(double metres, double near_m = 0.3, double far_m = 8.0);
constexpr Rgb8 kNoDepthColour{40, 40, 44};

struct OverlayOptions {
  double near_m = 0.3;  ///< colour scale of the depth image (m), the same in every frame
  double far_m = 8.0;
  double match_radius = 1.0;  ///< m, top-view centre distance of a "found" person / real obstacle
  // A reference obstacle is a "reference person" (counted, can be MISSED) when it moves at least
  // this fast, is at least this visible and its centre is this far ahead of the camera: the
  // ground truth dynamap-eval counts (docs/tools.md).
  double moving_speed = 0.2;
  double min_visible = 0.5;
  double min_depth = 0.5;
  double max_depth = 5.0;
};

/// What one frame's picture shows, in plain data.
struct OverlayFrame {
  std::size_t index = 0;  ///< position in Sequence::frames
  std::string stamp_text;
  PoseD pose;                  ///< T_world_camera
  bool depth_ok = false;       ///< false: drawn as "depth missing"
  Image16 depth;               ///< when depth_ok
  bool has_reference = false;  ///< a reference file was given: missed / false are meaningful
  bool after_result = false;   ///< later than the result's last stamp (replay stopped early)
  std::vector<TrackRow> tracks;
  std::vector<DetectionRow> detections;
  std::vector<ObstacleRecord> reference;  ///< every reference obstacle listed at this stamp
};

/// How each drawn thing is classified, and the caption's counts.
enum class ReferenceKind { kPerson, kMissed, kOther };  // kOther: listed but not counted
struct FrameAnalysis {
  std::vector<bool> false_dynamic;       ///< per track: dynamic, no reference within radius
  std::vector<ReferenceKind> reference;  ///< per reference obstacle
  int dynamic_tracks = 0;
  int static_tracks = 0;
  int reference_people = 0;  ///< reference obstacles counted (kPerson + kMissed)
  int missed = 0;
  int false_dynamic_count = 0;
};

/// Classifies tracks and reference obstacles of one frame (top-view centre distances). Without a
/// reference nothing is missed or false.
FrameAnalysis analyse_frame(const OverlayFrame& frame, const OverlayOptions& options);

/// Pixel sizes of the pictures (the layout is fixed; tests check the files against these).
struct PictureSize {
  int width = 0, height = 0;
};
PictureSize frame_picture_size(const CameraModel& camera);
PictureSize contact_sheet_size(const CameraModel& camera, std::size_t tiles, int columns);

/// One full-size picture: the image at 1:1 with the overlays, a caption below, a colour bar and
/// the legend on the right. Throws ToolError when the file cannot be written.
void render_overlay_frame(const OverlayFrame& frame, const CameraModel& camera,
                          const OverlayOptions& options, const std::string& png_path);

/// A grid of thumbnails (each with its frame number and missed / false counts), a title, a
/// summary line and the legend. Throws ToolError when the file cannot be written.
void render_contact_sheet(const std::vector<OverlayFrame>& tiles, const CameraModel& camera,
                          const OverlayOptions& options, const std::string& title,
                          const std::string& summary, const std::string& png_path, int columns = 6);

/// Everything the command line says.
struct RunOptions {
  std::string seq;
  std::string result_dir;
  std::string out_dir;        ///< empty: RESULT_DIR/overlay
  std::string reference;      ///< empty: SEQ/obstacles.txt when it exists
  int every = 30;             ///< a picture every N sequence frames (0: none)
  long long max_frames = -1;  ///< only the first N frames of the sequence (-1: all)
  int sheet_columns = 6;
  int sheet_tiles = 36;  ///< about this many thumbnails (rounded up to full rows)
  OverlayOptions overlay;
  std::function<void(const std::string&)> progress;  ///< one line at a time; may be empty
};

struct RunSummary {
  std::size_t frames = 0;                 ///< sequence frames considered
  std::size_t pictures = 0;               ///< frame_NNNNN.png written
  std::size_t tiles = 0;                  ///< thumbnails on the contact sheet
  std::size_t depth_missing = 0;          ///< frames drawn whose depth was missing or unreadable
  std::vector<std::string> depth_errors;  ///< the first few messages
  std::size_t depth_files_missing = 0;    ///< listed frames (drawn or not) whose file is absent
  bool has_reference = false;
  bool has_detections = false;
  std::string reference_path;
  // Over every considered frame (not only the drawn ones):
  std::size_t reference_people = 0;  ///< person-frames
  std::size_t missed = 0;
  std::size_t dynamic_tracks = 0;  ///< dynamic track-frames
  std::size_t false_dynamic = 0;
  std::size_t frames_after_result = 0;  ///< later than the last stamp of tracks.csv
  /// Per considered frame (index in Sequence::frames): missed and false dynamic counts.
  std::vector<int> missed_per_frame;
  std::vector<int> false_per_frame;
  std::vector<std::string> written;  ///< paths of every PNG written
};

/// Reads the sequence and the result, writes DIR/frame_NNNNN.png and DIR/contact_sheet.png.
/// Throws ToolError for unreadable inputs (naming the file); a missing depth image is drawn as
/// "depth missing" and counted instead.
RunSummary run_overlay(const RunOptions& options);

}  // namespace dynamap::tools::overlay
