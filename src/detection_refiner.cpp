#include "dynamap/detection_refiner.hpp"

#include <algorithm>
#include <cmath>

namespace dynamap {

namespace {

Box3 box_union(const Box3& a, const Box3& b) noexcept {
  return Box3{a.min.cwiseMin(b.min), a.max.cwiseMax(b.max)};
}

ImageBox image_union(const ImageBox& a, const ImageBox& b) noexcept {
  if (a.u1 < a.u0 || a.v1 < a.v0) return b;  // empty / unknown
  if (b.u1 < b.u0 || b.v1 < b.v0) return a;
  return ImageBox{std::min(a.u0, b.u0), std::min(a.v0, b.v0), std::max(a.u1, b.u1),
                  std::max(a.v1, b.v1)};
}

}  // namespace

Status DetectionRefinerConfig::validate() const noexcept {
  const bool good = std::isfinite(max_gap) && max_gap <= 1.f && std::isfinite(max_footprint) &&
                    max_footprint > 0.f && max_footprint <= 5.f;
  return good ? Status::kOk : Status::kInvalidArgument;
}

Status DetectionRefiner::init(const DetectionRefinerConfig& config) noexcept {
  const Status s = config.validate();
  if (!ok(s)) return s;
  config_ = config;
  return Status::kOk;
}

bool DetectionRefiner::joinable(const Detection& a, const Detection& b) const noexcept {
  const Box3& p = a.raw_box;
  const Box3& q = b.raw_box;
  for (int axis = 0; axis < 2; ++axis) {
    const float gap = std::max(p.min[axis] - q.max[axis], q.min[axis] - p.max[axis]);
    if (gap > config_.max_gap) return false;
  }
  const Box3 joined = box_union(p, q);
  return std::max(joined.size().x(), joined.size().y()) <= config_.max_footprint;
}

std::size_t DetectionRefiner::join(DetectionList& dets) const noexcept {
  if (!config_.join_fragments) return 0;
  std::size_t joins = 0;
  // Each join removes one detection, so the scan runs at most kMaxDetections times.
  bool joined = true;
  while (joined) {
    joined = false;
    for (std::size_t i = 0; i < dets.size() && !joined; ++i) {
      for (std::size_t j = i + 1; j < dets.size() && !joined; ++j) {
        if (!joinable(dets[i], dets[j])) continue;
        Detection& a = dets[i];
        const Detection& b = dets[j];
        a.box = box_union(a.box, b.box);
        a.raw_box = box_union(a.raw_box, b.raw_box);
        a.image_box = image_union(a.image_box, b.image_box);
        a.near_depth = std::min(a.near_depth, b.near_depth);
        a.refined = a.refined && b.refined;
        for (std::size_t k = j + 1; k < dets.size(); ++k) dets[k - 1] = dets[k];
        dets.pop_back();
        ++joins;
        joined = true;
      }
    }
  }
  return joins;
}

}  // namespace dynamap
