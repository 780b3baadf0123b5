// Tests of the reference labeller (tools/label, docs/reference_labels.md): it reproduces the
// simulator's moving people, labels nobody who only stands, skips missing depth files, and
// runs on a section of the real Bonn "crowd" sequence when that is present.
#include <gtest/gtest.h>

#include <stdlib.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <string>

#include "common/obstacles.hpp"
#include "common/results.hpp"
#include "common/sequence.hpp"
#include "common/text_io.hpp"
#include "eval/metrics.hpp"
#include "label/labeller.hpp"
#include "sim/scene.hpp"
#include "sim/writer.hpp"

namespace fs = std::filesystem;
using namespace dynamap::tools;

namespace {

// One temporary directory per test process, removed at exit; each test uses a subdirectory.
class ProcessTempDir {
 public:
  static const std::string& path() {
    static ProcessTempDir dir;
    return dir.path_;
  }
  ~ProcessTempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }

 private:
  ProcessTempDir() {
    char tmpl[] = "/tmp/dynamap_test_label_XXXXXX";
    const char* p = ::mkdtemp(tmpl);
    if (p == nullptr) throw std::runtime_error("mkdtemp failed");
    path_ = p;
  }
  std::string path_;
};

std::string simulate_scene(const std::string& scene, int frames, std::uint64_t seed) {
  const std::string dir = ProcessTempDir::path() + "/" + scene + "_" + std::to_string(frames) +
                          "_" + std::to_string(seed);
  if (!fs::exists(dir + "/obstacles.txt")) {
    sim::SimulateOptions so;
    so.frames = frames;
    so.seed = seed;
    so.picture = false;
    sim::simulate(sim::make_scene(scene, seed), dir, so);
  }
  return dir;
}

}  // namespace

TEST(Label, ReproducesTheSimulatedWalkersOfEnvC) {
  const std::string seq = simulate_scene("env_c", 110, 1);
  const label::LabelOptions opt;
  const label::LabelResult r = label::label_sequence(seq, opt);
  EXPECT_EQ(r.summary.frames, 110u);
  EXPECT_TRUE(r.summary.skipped.empty());
  EXPECT_GE(r.summary.tracks, 1u);
  const std::string out = ProcessTempDir::path() + "/labels_env_c";
  label::write_labels(out, r, opt);

  const eval::EvalResult e = eval::evaluate(seq, out);
  ASSERT_GT(e.gt_count, 50u);
  EXPECT_GE(e.recall, 0.9) << eval::format_table(e);
  EXPECT_GE(e.precision, 0.9) << eval::format_table(e);
  EXPECT_LE(e.position_error, 0.15) << eval::format_table(e);

  // Both files hold the same rows, readable by the project's readers; the header says how
  // the labels were made.
  const auto obstacles = read_obstacles(out + "/obstacles.txt");
  const auto tracks = read_tracks_csv(out + "/tracks.csv");
  ASSERT_EQ(obstacles.size(), r.rows.size());
  ASSERT_EQ(tracks.size(), r.rows.size());
  for (std::size_t k = 0; k < tracks.size(); ++k) {
    EXPECT_TRUE(tracks[k].dynamic);
    EXPECT_EQ(tracks[k].path, -1);
    EXPECT_EQ(tracks[k].id, obstacles[k].id);
    EXPECT_NEAR(tracks[k].center.x(), obstacles[k].center.x(), 1e-3);
    EXPECT_GE(obstacles[k].visible, 0.0);
    EXPECT_LE(obstacles[k].visible, 1.0);
  }
  const auto lines = read_lines(out + "/obstacles.txt");
  ASSERT_FALSE(lines.empty());
  EXPECT_NE(lines[0].find("made by dynamap-label from the depth data"), std::string::npos);
}

TEST(Label, LabelsNobodyWhoOnlyStands) {
  const std::string seq = simulate_scene("standing", 60, 1);
  const label::LabelResult r = label::label_sequence(seq);
  EXPECT_EQ(r.summary.frames, 60u);
  EXPECT_EQ(r.summary.tracks, 0u);
  EXPECT_TRUE(r.rows.empty());
}

TEST(Label, SkipsAndCountsAListedButMissingDepthFile) {
  const std::string seq = simulate_scene("env_c", 110, 1);
  const std::string copy = ProcessTempDir::path() + "/env_c_missing";
  fs::remove_all(copy);
  fs::copy(seq, copy, fs::copy_options::recursive);
  const Sequence s = read_sequence(copy);
  ASSERT_GT(s.frames.size(), 40u);
  fs::remove(s.frames[40].depth_path);

  const label::LabelResult r = label::label_sequence(copy);
  EXPECT_EQ(r.summary.frames, 110u);
  EXPECT_EQ(r.summary.frames_used, 109u);
  ASSERT_EQ(r.summary.skipped.size(), 1u);
  EXPECT_NE(r.summary.skipped[0].find(s.frames[40].depth_path), std::string::npos)
      << r.summary.skipped[0];
  // The missing frame is inside the people's tracks: filled by interpolation, not visible.
  bool filled = false;
  for (const auto& row : r.rows) {
    if (row.stamp_text == s.frames[40].stamp_text) {
      filled = true;
      EXPECT_EQ(row.visible, 0.0);
    }
  }
  EXPECT_TRUE(filled);
}

TEST(Label, FindsWalkingPeopleInBonnCrowd) {
  const std::string dir = DYNAMAP_BONN_CROWD_DIR;
  if (!fs::exists(dir + "/depth.txt")) {
    GTEST_SKIP() << "../shared/data/bonn_crowd not found: real-data test skipped";
  }
  // Nobody is in view during the first 7 s: frames 230-319 have two or three people walking
  // close to the camera.
  label::LabelOptions opt;
  opt.first_frame = 230;
  opt.max_frames = 90;
  const label::LabelResult r = label::label_sequence(dir, opt);
  EXPECT_EQ(r.summary.frames, 90u);
  EXPECT_EQ(r.summary.frames_used + r.summary.skipped.size(), 90u);
  EXPECT_GE(r.summary.tracks, 2u) << "people walk in view in these frames";
  for (const auto& row : r.rows) {
    EXPECT_TRUE(row.center.allFinite());
    EXPECT_TRUE(row.velocity.allFinite());
    EXPECT_LT(row.velocity.head<2>().norm(), 3.0) << "a walking person, not a jump";
    EXPECT_GT(row.size.z(), 0.8);
  }
}
