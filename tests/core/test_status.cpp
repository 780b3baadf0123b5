#include <cstring>

#include <gtest/gtest.h>

#include "dynamap/core/status.hpp"
#include "dynamap/core/types.hpp"

namespace dynamap {
namespace {

TEST(Status, EveryValueHasADistinctName) {
  const Status all[] = {Status::kOk,
                        Status::kInvalidArgument,
                        Status::kNullData,
                        Status::kWrongSize,
                        Status::kNonFinite,
                        Status::kNonUnitQuaternion,
                        Status::kTimeNotIncreasing,
                        Status::kCapacityExceeded,
                        Status::kNotInitialized,
                        Status::kPermissionDenied,
                        Status::kUnsupported,
                        Status::kSystemError,
                        Status::kEmpty,
                        Status::kOutOfRange,
                        Status::kStopped};
  for (Status a : all) {
    EXPECT_STRNE(to_string(a), "unknown");
    for (Status b : all) {
      if (a != b) {
        EXPECT_STRNE(to_string(a), to_string(b));
      }
    }
  }
  EXPECT_TRUE(ok(Status::kOk));
  EXPECT_FALSE(ok(Status::kWrongSize));
}

TEST(Validation, PoseChecksFinitenessAndUnitQuaternion) {
  Pose p;
  EXPECT_EQ(validate_pose(p), Status::kOk);
  p.translation.x() = std::nanf("");
  EXPECT_EQ(validate_pose(p), Status::kNonFinite);
  p = Pose{};
  p.rotation.coeffs() << 0.f, 0.f, 0.f, 1.1f;
  EXPECT_EQ(validate_pose(p), Status::kNonUnitQuaternion);
}

TEST(Pose, ApplyInverseUndoesApply) {
  Pose p;
  p.translation = Eigen::Vector3f(1.f, -2.f, 0.5f);
  p.rotation =
      Eigen::Quaternionf(Eigen::AngleAxisf(0.7f, Eigen::Vector3f(1.f, 2.f, 3.f).normalized()));
  const Eigen::Vector3f x(0.3f, 4.f, -1.f);
  EXPECT_LT((p.apply_inverse(p.apply(x)) - x).norm(), 1e-5f);
  EXPECT_LT((p.apply(p.apply_inverse(x)) - x).norm(), 1e-5f);
  EXPECT_LT(p.apply_inverse(p.translation).norm(), 1e-6f);  // the pose's origin
  // A quarter turn about z: the outer frame's x axis is this frame's -y.
  p = Pose{};
  p.rotation = Eigen::Quaternionf(Eigen::AngleAxisf(1.5707963f, Eigen::Vector3f::UnitZ()));
  EXPECT_LT((p.apply_inverse(Eigen::Vector3f::UnitX()) + Eigen::Vector3f::UnitY()).norm(), 1e-6f);
}

TEST(Validation, DepthViewChecksNullSizeAndStride) {
  CameraIntrinsics cam;
  cam.width = 4;
  cam.height = 2;
  std::uint16_t buf[8] = {};
  DepthView d{buf, 4, 2, 8};
  EXPECT_EQ(validate_depth(d, cam), Status::kOk);
  EXPECT_EQ(validate_depth(DepthView{nullptr, 4, 2, 8}, cam), Status::kNullData);
  EXPECT_EQ(validate_depth(DepthView{buf, 3, 2, 8}, cam), Status::kWrongSize);
  EXPECT_EQ(validate_depth(DepthView{buf, 4, 2, 6}, cam), Status::kWrongSize);
}

}  // namespace
}  // namespace dynamap
