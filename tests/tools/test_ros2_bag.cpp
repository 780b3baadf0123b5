// ROS 2 bags: the MCAP reader and writer, CDR and ros2msg decoding, the two real bags recorded by
// rosbag2 (../shared/data/rosbag2, skipped when absent), bags as sequences (folder -> bag gives
// the same frames and poses), and damaged bags (truncated at every byte, a flipped CRC, an
// unknown compression, a topic of the wrong type, an image whose step lies, a broken tf chain).
#include <gtest/gtest.h>

#include <unistd.h>
#include "temp_dir.hpp"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "common/cdr.hpp"
#include "common/mcap_reader.hpp"
#include "common/mcap_writer.hpp"
#include "common/png_io.hpp"
#include "common/ros2_bag.hpp"
#include "common/ros2_convert.hpp"
#include "common/sequence.hpp"
#include "common/text_io.hpp"

namespace fs = std::filesystem;
using namespace dynamap::tools;

namespace {

using dynamap::test::TempDir;

/// The rest of a sensor_msgs/CameraInfo after its header: 6 x 8 px, plumb_bob without
/// distortion, K with f = 10 px and centre (4, 3), R, P and the binning and ROI zero.
void write_camera_info_body(cdr::Writer& c) {
  c.write<std::uint32_t>(6);
  c.write<std::uint32_t>(8);
  c.string("plumb_bob");
  c.write<std::uint32_t>(0);
  for (double v : {10., 0., 4., 0., 10., 3., 0., 0., 1.}) c.write<double>(v);
  for (int k = 0; k < 21; ++k) c.write<double>(0.0);
  for (int k = 0; k < 6; ++k) c.write<std::uint32_t>(0);
  c.write<std::uint8_t>(0);
}

std::string read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

void write_bytes(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
}

const std::string kShared = DYNAMAP_SHARED_DATA_DIR "/rosbag2";

// A small sequence folder: 6 depth images 8x6, poses at other stamps, camera.txt.
void make_sequence(const std::string& dir) {
  fs::create_directories(dir + "/depth");
  std::ofstream cam(dir + "/camera.txt");
  cam << "fx 10\nfy 11\ncx 4\ncy 3\nwidth 8\nheight 6\ndepth_factor 5000\nworld_z_up 1\n";
  std::ofstream depth(dir + "/depth.txt");
  std::ofstream gt(dir + "/groundtruth.txt");
  depth << "# depth\n";
  for (int k = 0; k < 6; ++k) {
    Image16 img{8, 6, std::vector<std::uint16_t>(48)};
    for (int p = 0; p < 48; ++p) img.pixels[p] = static_cast<std::uint16_t>(1000 * k + p);
    const std::string stamp = "1548339819." + std::to_string(10000 + 3333 * k);
    write_png16(dir + "/depth/" + stamp + ".png", img);
    depth << stamp << " depth/" << stamp << ".png\n";
  }
  for (int k = 0; k < 14; ++k) {
    gt << "1548339819." << 9000 + 1700 * k << " " << 0.1 * k << " 1.5 " << 1.0 + 0.01 * k
       << " 0.70710678 0.0 0.01 0.70710678\n";
  }
}

}  // namespace

TEST(McapReader, TheTwoRealBagsDecodeCompletely) {
  if (!fs::exists(kShared + "/talker/talker.mcap")) {
    GTEST_SKIP() << kShared << " is absent: the real rosbag2 bags are not checked";
  }
  Ros2Bag talker(kShared + "/talker");
  EXPECT_TRUE(talker.problems().empty());
  ASSERT_NE(talker.topic("/topic"), nullptr);
  EXPECT_EQ(talker.topic("/topic")->type, "std_msgs/msg/String");
  const auto msgs = talker.messages("/topic");
  ASSERT_EQ(msgs.size(), 10u);
  for (std::size_t k = 0; k < msgs.size(); ++k) {
    EXPECT_EQ(talker.decode(msgs[k])["data"].s, "Hello, world! " + std::to_string(k));
  }
  const auto log = talker.messages("/rosout");
  ASSERT_EQ(log.size(), 10u);
  EXPECT_EQ(talker.decode(log[0])["name"].s, "minimal_publisher");
  EXPECT_EQ(talker.decode(log[0])["line"].number(), 38);

  Ros2Bag cdr(kShared + "/cdr_test");
  EXPECT_TRUE(cdr.problems().empty());
  const auto basic = cdr.messages("/test_topic");
  ASSERT_EQ(basic.size(), 3u);
  const auto arrays = cdr.messages("/array_topic");
  ASSERT_EQ(arrays.size(), 4u);
  const ros2msg::Value a = cdr.decode(arrays[0]);
  EXPECT_EQ(a["string_values"].items.at(1).s, "Complex Hello2");
  EXPECT_EQ(a["defaults_values"].items.at(0)["int16_value"].number(), -1000);
  EXPECT_EQ(a["defaults_values"].items.at(0)["float32_value"].number(), 1.125);
  EXPECT_EQ(a["defaults_values"].items.at(0)["uint64_value"].u, 50000000u);
  for (const auto& m : basic) EXPECT_NO_THROW(cdr.decode(m));
}

TEST(McapReader, WrittenFilesReadBackIndexedAndScanned) {
  TempDir tmp;
  for (const std::string compression : {"", "zstd", "lz4"}) {
    const std::string path = tmp / ("w" + compression + ".mcap");
    {
      mcap::Writer w(path, "ros2", compression, 300);
      const auto s = w.add_schema("std_msgs/msg/String", "ros2msg", "string data\n");
      const auto c = w.add_channel(s, "/chatter", "cdr");
      for (int k = 0; k < 50; ++k) {
        cdr::Writer m;
        m.string("message " + std::to_string(k));
        w.write(c, 1000 + k, 1000 + k, m.data().data(), m.data().size());
      }
      w.add_metadata("info", {{"key", "value"}});
      w.close();
    }
    mcap::Reader r(path);
    EXPECT_TRUE(r.used_summary()) << compression;
    EXPECT_TRUE(r.warnings().empty()) << compression;
    EXPECT_TRUE(r.damage().empty()) << compression;
    ASSERT_EQ(r.messages().size(), 50u) << compression;
    ASSERT_EQ(r.metadata().size(), 1u);
    EXPECT_EQ(r.metadata()[0].values.at("key"), "value");
    Ros2Bag bag(path);
    const auto msgs = bag.messages("/chatter");
    EXPECT_EQ(bag.decode(msgs[49])["data"].s, "message 49");
    // Without the footer: a linear scan finds the same messages and reports the cut.
    const std::string bytes = read_bytes(path);
    write_bytes(tmp / "cut.mcap", bytes.substr(0, bytes.size() - 8));
    mcap::Reader cut(tmp / "cut.mcap");
    EXPECT_FALSE(cut.used_summary());
    EXPECT_EQ(cut.messages().size(), 50u);
  }
}

TEST(McapReader, TruncatedAtAnyByteFlippedCrcAndUnknownCompression) {
  TempDir tmp;
  const std::string path = tmp / "z.mcap";
  {
    mcap::Writer w(path, "ros2", "zstd", 200);
    const auto s = w.add_schema("std_msgs/msg/String", "ros2msg", "string data\n");
    const auto c = w.add_channel(s, "/chatter", "cdr");
    for (int k = 0; k < 20; ++k) {
      cdr::Writer m;
      m.string("message " + std::to_string(k));
      w.write(c, 1000 + k, 1000 + k, m.data().data(), m.data().size());
    }
  }
  const std::string bytes = read_bytes(path);
  for (std::size_t n = 0; n < bytes.size(); ++n) {
    write_bytes(tmp / "t.mcap", bytes.substr(0, n));
    try {
      mcap::Reader r(tmp / "t.mcap");
      EXPECT_FALSE(r.damage().empty() && r.messages().size() < 20) << "cut at " << n;
      EXPECT_LE(r.messages().size(), 20u);
    } catch (const ToolError& e) {
      EXPECT_LT(n, 8u) << e.what();  // only without the whole magic
    }
  }
  // A flipped byte inside the first chunk's compressed records: that chunk is skipped, named.
  mcap::Reader good(path);
  ASSERT_GE(good.chunks().size(), 2u);
  std::string flipped = bytes;
  flipped[good.chunks()[0].data_offset + good.chunks()[0].data_size - 3] ^= 0x40;
  write_bytes(tmp / "f.mcap", flipped);
  mcap::Reader f(tmp / "f.mcap");
  ASSERT_FALSE(f.warnings().empty());
  EXPECT_NE(f.warnings()[0].find("at byte " + std::to_string(good.chunks()[0].file_offset)),
            std::string::npos)
      << f.warnings()[0];
  EXPECT_LT(f.messages().size(), 20u);
  // An unknown compression name: the chunk is skipped with a warning naming it.
  std::string unknown = bytes;
  const auto at = unknown.find("zstd");
  unknown.replace(at, 4, "brot");
  write_bytes(tmp / "u.mcap", unknown);
  mcap::Reader u(tmp / "u.mcap");
  ASSERT_FALSE(u.warnings().empty());
  EXPECT_NE(u.warnings()[0].find("unknown compression 'brot'"), std::string::npos)
      << u.warnings()[0];
}

TEST(Ros2Bag, FolderToBagGivesTheSameFramesAndPoses) {
  TempDir tmp;
  make_sequence(tmp / "seq");
  std::ofstream(tmp / "seq/depth.txt", std::ios::app) << "1548339819.29 depth/gone.png\n";
  BagWriteOptions w;
  const ConvertReport r = folder_to_bag(tmp / "seq", tmp / "bag", w);
  EXPECT_EQ(r.images, 6u);
  EXPECT_EQ(r.skipped, 1u);
  EXPECT_TRUE(is_ros2_bag(tmp / "bag"));
  EXPECT_TRUE(fs::exists(tmp / "bag/metadata.yaml"));
  const Sequence a = read_sequence(tmp / "seq");
  const Sequence b = read_sequence(tmp / "bag");
  ASSERT_EQ(a.frames.size(), b.frames.size());
  EXPECT_EQ(b.camera.fx, 10);
  EXPECT_EQ(b.camera.depth_factor, 5000);
  EXPECT_EQ(b.camera.world_z_up, 1);
  EXPECT_EQ(a.images_listed, b.images_listed);
  EXPECT_EQ(a.images_without_pose, b.images_without_pose);
  for (std::size_t k = 0; k < a.frames.size(); ++k) {
    EXPECT_EQ(a.frames[k].stamp_text, b.frames[k].stamp_text);
    EXPECT_EQ(a.frames[k].stamp, b.frames[k].stamp);
    EXPECT_EQ(a.frames[k].pose.translation, b.frames[k].pose.translation);
    EXPECT_EQ(a.frames[k].pose.rotation.coeffs(), b.frames[k].pose.rotation.coeffs());
    Image16 ia, ib;
    std::string ma, mb;
    const DepthProblem pa = try_load_depth(a, a.frames[k], &ia, &ma);
    // The missing file is listed in the bag too and reported with the folder's words.
    EXPECT_EQ(pa, try_load_depth(b, b.frames[k], &ib, &mb));
    EXPECT_EQ(ma, mb);
    if (pa == DepthProblem::kNone) {
      EXPECT_EQ(ia.pixels, ib.pixels);
    }
  }
  // And back to a folder: the same again.
  bag_to_folder(tmp / "bag", tmp / "back", {});
  const Sequence c = read_sequence(tmp / "back");
  ASSERT_EQ(c.frames.size(), a.frames.size());
  for (std::size_t k = 0; k < a.frames.size(); ++k) {
    EXPECT_EQ(a.frames[k].stamp_text, c.frames[k].stamp_text);
    EXPECT_EQ(a.frames[k].pose.translation, c.frames[k].pose.translation);
    EXPECT_EQ(a.frames[k].pose.rotation.coeffs(), c.frames[k].pose.rotation.coeffs());
    Image16 ia, ic;
    std::string ma, mc;
    if (try_load_depth(a, a.frames[k], &ia, &ma) == DepthProblem::kNone) {
      EXPECT_EQ(try_load_depth(c, c.frames[k], &ic, &mc), DepthProblem::kNone) << mc;
      EXPECT_EQ(ia.pixels, ic.pixels);
    }
  }
}

TEST(Ros2Bag, WrongTopicTypeAndLyingImagesAreNamed) {
  TempDir tmp;
  make_sequence(tmp / "seq");
  folder_to_bag(tmp / "seq", tmp / "b.mcap", {});
  SequenceReadOptions o;
  o.bag.depth_topic = "/camera/pose";
  try {
    read_sequence(tmp / "b.mcap", o);
    FAIL() << "a pose topic read as images";
  } catch (const ToolError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("topic /camera/pose has type geometry_msgs/msg/PoseStamped"),
              std::string::npos)
        << m;
    EXPECT_NE(m.find("/camera/depth/image_rect_raw  sensor_msgs/msg/Image"), std::string::npos)
        << m;
  }
  // A bag whose image says 8 pixels a row but whose step and data hold fewer.
  {
    mcap::Writer w(tmp / "lie.mcap", "ros2", "");
    auto ch = [&](const std::string& topic, const std::string& type) {
      return w.add_channel(w.add_schema(type, "ros2msg", builtin_schema(type)), topic, "cdr");
    };
    const auto img = ch("/depth", "sensor_msgs/msg/Image");
    const auto pose = ch("/pose", "geometry_msgs/msg/PoseStamped");
    const auto info = ch("/info", "sensor_msgs/msg/CameraInfo");
    for (int k = 0; k < 3; ++k) {
      cdr::Writer m;
      m.write<std::int32_t>(100 + k);
      m.write<std::uint32_t>(0);
      m.string("cam");
      m.write<std::uint32_t>(6);
      m.write<std::uint32_t>(8);
      m.string(k == 1 ? "rgb8" : "16UC1");
      m.write<std::uint8_t>(0);
      m.write<std::uint32_t>(k == 2 ? 10 : 16);
      m.write<std::uint32_t>(60);
      m.bytes(std::string(60, '\1').data(), 60);
      w.write(img, 0, 0, m.data().data(), m.data().size());
      cdr::Writer p;
      p.write<std::int32_t>(100 + k);
      p.write<std::uint32_t>(0);
      p.string("world");
      for (double v : {0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0}) p.write<double>(v);
      w.write(pose, 0, 0, p.data().data(), p.data().size());
    }
    cdr::Writer c;
    c.write<std::int32_t>(100);
    c.write<std::uint32_t>(0);
    c.string("cam");
    write_camera_info_body(c);
    w.write(info, 0, 0, c.data().data(), c.data().size());
  }
  SequenceReadOptions z;
  z.bag.world_z_up = 1;
  const Sequence s = read_sequence(tmp / "lie.mcap", z);
  ASSERT_EQ(s.frames.size(), 3u);
  Image16 out;
  std::string why;
  EXPECT_EQ(try_load_depth(s, s.frames[0], &out, &why), DepthProblem::kUnreadable) << why;
  EXPECT_NE(why.find("step 16 and 60 data bytes"), std::string::npos) << why;
  EXPECT_NE(why.find("topic /depth image at 100.000000000"), std::string::npos) << why;
  EXPECT_EQ(try_load_depth(s, s.frames[1], &out, &why), DepthProblem::kUnreadable);
  EXPECT_NE(why.find("encoding 'rgb8'"), std::string::npos) << why;
  EXPECT_EQ(try_load_depth(s, s.frames[2], &out, &why), DepthProblem::kUnreadable);
}

namespace {

void stamp(cdr::Writer& w, int sec, const std::string& frame) {
  w.write<std::int32_t>(sec);
  w.write<std::uint32_t>(0);
  w.string(frame);
}

void pose7(cdr::Writer& w, const std::vector<double>& v) {
  for (double x : v) w.write<double>(x);
}

// Images of 8x6 at t = 10..14 s in "cam_optical", odometry of "base_link" in "odom" at 9..15 s,
// and (with_static) /tf_static base_link -> cam_optical: a quarter turn about z and 0.2 m up.
void write_odometry_bag(const std::string& path, bool with_static, bool tf_only = false,
                        bool metres = false) {
  mcap::Writer w(path, "ros2", "zstd");
  auto ch = [&](const std::string& topic, const std::string& type) {
    return w.add_channel(w.add_schema(type, "ros2msg", builtin_schema(type)), topic, "cdr");
  };
  const auto img = ch("/cam/depth", "sensor_msgs/msg/Image");
  const auto info = ch("/cam/camera_info", "sensor_msgs/msg/CameraInfo");
  const auto odom = tf_only ? 0 : ch("/odom", "nav_msgs/msg/Odometry");
  const auto tf = ch("/tf_static", "tf2_msgs/msg/TFMessage");
  const auto tf_dyn = ch("/tf", "tf2_msgs/msg/TFMessage");
  if (with_static) {
    cdr::Writer m;
    m.write<std::uint32_t>(1);
    stamp(m, 0, "base_link");
    m.string("cam_optical");
    pose7(m, {0, 0, 0.2, 0, 0, 0.70710678118654757, 0.70710678118654757});
    w.write(tf, 1, 1, m.data().data(), m.data().size());
  }
  for (int s = 9; s <= 15 && tf_only; ++s) {  // the same motion as /tf odom -> base_link
    cdr::Writer m;
    m.write<std::uint32_t>(1);
    stamp(m, s, "odom");
    m.string("base_link");
    pose7(m, {1.0 * s, 2, 0, 0, 0, 0, 1});
    w.write(tf_dyn, s * 1000000000ull, 0, m.data().data(), m.data().size());
  }
  for (int s = 9; s <= 15 && !tf_only; ++s) {
    cdr::Writer m;
    stamp(m, s, "odom");
    m.string("base_link");
    pose7(m, {1.0 * s, 2, 0, 0, 0, 0, 1});
    for (int k = 0; k < 36; ++k) m.write<double>(0);
    pose7(m, {0, 0, 0, 0, 0, 0});
    for (int k = 0; k < 36; ++k) m.write<double>(0);
    w.write(odom, s * 1000000000ull, 0, m.data().data(), m.data().size());
  }
  for (int s = 10; s <= 14; ++s) {
    cdr::Writer m;
    stamp(m, s, "cam_optical");
    m.write<std::uint32_t>(6);
    m.write<std::uint32_t>(8);
    m.string(metres ? "32FC1" : "16UC1");
    m.write<std::uint8_t>(0);
    m.write<std::uint32_t>(metres ? 32 : 16);
    m.write<std::uint32_t>(metres ? 192 : 96);
    if (metres) {
      for (int p = 0; p < 48; ++p) m.write<float>(p == 0 ? NAN : 1.2345f);
    } else {
      m.bytes(std::vector<std::uint8_t>(96, 7).data(), 96);
    }
    w.write(img, s * 1000000000ull, 0, m.data().data(), m.data().size());
    cdr::Writer c;
    stamp(c, s, "cam_optical");
    write_camera_info_body(c);
    w.write(info, s * 1000000000ull, 0, c.data().data(), c.data().size());
  }
}

}  // namespace

TEST(Ros2Bag, OdometryIsChainedThroughStaticTransformsToTheOpticalFrame) {
  TempDir tmp;
  write_odometry_bag(tmp / "odom.mcap", true);
  SequenceReadOptions o;
  o.bag.world_z_up = 1;
  const Sequence s = read_sequence(tmp / "odom.mcap", o);
  ASSERT_EQ(s.frames.size(), 5u);
  EXPECT_EQ(s.frames[0].stamp_text, "10.000000000");
  EXPECT_NEAR((s.frames[2].pose.translation - Eigen::Vector3d(12, 2, 0.2)).norm(), 0, 1e-12);
  const Eigen::Vector3d x = s.frames[2].pose.rotation * Eigen::Vector3d::UnitX();
  EXPECT_NEAR((x - Eigen::Vector3d::UnitY()).norm(), 0, 1e-9);  // the quarter turn
  EXPECT_EQ(load_depth(s, s.frames[0]).pixels[5], 0x0707);
  EXPECT_NE(s.pose_file.find("base_link -> cam_optical"), std::string::npos) << s.pose_file;

  // 32FC1 depth in metres: read in millimetres, NaN as no measurement.
  write_odometry_bag(tmp / "metres.mcap", true, false, true);
  const Sequence f = read_sequence(tmp / "metres.mcap", o);
  EXPECT_EQ(f.camera.depth_factor, 1000);
  EXPECT_EQ(load_depth(f, f.frames[0]).pixels[0], 0);
  EXPECT_EQ(load_depth(f, f.frames[0]).pixels[1], 1235);
  // The same motion on /tf alone (no pose topic): the chain odom -> base_link -> cam_optical.
  write_odometry_bag(tmp / "tf.mcap", true, true);
  const Sequence t = read_sequence(tmp / "tf.mcap", o);
  ASSERT_EQ(t.frames.size(), 5u);
  EXPECT_NEAR((t.frames[2].pose.translation - Eigen::Vector3d(12, 2, 0.2)).norm(), 0, 1e-12);
  EXPECT_NE(t.pose_file.find("(odom -> cam_optical)"), std::string::npos) << t.pose_file;

  write_odometry_bag(tmp / "broken.mcap", false);
  try {
    read_sequence(tmp / "broken.mcap", o);
    FAIL() << "a pose chain with a missing link was accepted";
  } catch (const ToolError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("broken.mcap: pose chain from 'base_link' to the camera frame "
                     "'cam_optical' at 10.000000000: no transform from 'cam_optical'"),
              std::string::npos)
        << m;
  }
}

TEST(Ros2Bag, ATruncatedBagIsReadUpToTheDamageWhichIsNamed) {
  TempDir tmp;
  make_sequence(tmp / "seq");
  BagWriteOptions w;
  w.chunk_size = 600;  // about one image, its camera info and poses per chunk
  folder_to_bag(tmp / "seq", tmp / "whole.mcap", w);
  const std::size_t all = read_sequence(tmp / "seq").frames.size();
  EXPECT_EQ(read_sequence(tmp / "whole.mcap").frames.size(), all);
  const std::string bytes = read_bytes(tmp / "whole.mcap");
  write_bytes(tmp / "cut.mcap", bytes.substr(0, bytes.size() * 6 / 10));
  const Sequence s = read_sequence(tmp / "cut.mcap");
  EXPECT_GT(s.frames.size(), 0u);
  EXPECT_LT(s.frames.size(), all);
  // The metadata comes first: the cut bag keeps the depth unit, the world and the stamp texts.
  EXPECT_EQ(s.camera.depth_factor, 5000);
  EXPECT_EQ(s.camera.world_z_up, 1);
  EXPECT_EQ(s.frames.front().stamp_text, read_sequence(tmp / "seq").frames.front().stamp_text);
  ASSERT_FALSE(s.warnings.empty());
  EXPECT_NE(s.warnings.front().find("cut.mcap at byte"), std::string::npos) << s.warnings.front();
  EXPECT_NE(s.warnings.front().find("messages before it"), std::string::npos) << s.warnings.front();
}

namespace {

// Little-endian record bytes for a hand-made MCAP file.
struct Bytes {
  std::string b;
  template <class T>
  Bytes& num(T v) {
    b.append(reinterpret_cast<const char*>(&v), sizeof(T));
    return *this;
  }
  Bytes& str(const std::string& s) {
    num(static_cast<std::uint32_t>(s.size()));
    b += s;
    return *this;
  }
};

std::string record(std::uint8_t op, const std::string& body) {
  Bytes r;
  r.num(op).num(static_cast<std::uint64_t>(body.size()));
  return r.b + body;
}

}  // namespace

TEST(McapReader, AnUnchunkedFileWithoutSummaryIsScanned) {
  TempDir tmp;
  const std::string magic("\x89MCAP0\r\n", 8);
  cdr::Writer msg;
  msg.string("unchunked");
  std::string file = magic + record(mcap::kHeader, Bytes().str("ros2").str("hand").b);
  file += record(mcap::kSchema, Bytes()
                                    .num<std::uint16_t>(1)
                                    .str("std_msgs/msg/String")
                                    .str("ros2msg")
                                    .str("string data\n")
                                    .b);
  file += record(mcap::kChannel, Bytes()
                                     .num<std::uint16_t>(3)
                                     .num<std::uint16_t>(1)
                                     .str("/chatter")
                                     .str("cdr")
                                     .num<std::uint32_t>(0)
                                     .b);
  for (std::uint64_t t = 5; t < 8; ++t) {
    Bytes m;
    m.num<std::uint16_t>(3).num<std::uint32_t>(0).num(t).num(t);
    m.b.append(reinterpret_cast<const char*>(msg.data().data()), msg.data().size());
    file += record(mcap::kMessage, m.b);
  }
  file += record(mcap::kDataEnd, Bytes().num<std::uint32_t>(0).b);
  file += record(mcap::kFooter,
                 Bytes().num<std::uint64_t>(0).num<std::uint64_t>(0).num<std::uint32_t>(0).b);
  file += magic;
  write_bytes(tmp / "u.mcap", file);
  mcap::Reader r(tmp / "u.mcap");
  EXPECT_FALSE(r.used_summary());
  EXPECT_TRUE(r.damage().empty()) << r.damage();
  ASSERT_EQ(r.messages().size(), 3u);
  Ros2Bag bag(tmp / "u.mcap");
  EXPECT_EQ(bag.decode(bag.messages("/chatter").at(2))["data"].s, "unchunked");
}
