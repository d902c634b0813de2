// Box-track interpolation (instance_pose.h).
#include "engine/render/instance_pose.h"

#include <algorithm>

namespace pf {

Rigid BoxPose(const TrackBox& box) { return {ToMatrix(box.rotation), box.center}; }

TrackBox InterpolateBox(const std::vector<TrackBox>& boxes, int64_t timestamp_us) {
  if (boxes.empty()) return TrackBox{};
  if (timestamp_us <= boxes.front().timestamp_us) return boxes.front();
  if (timestamp_us >= boxes.back().timestamp_us) return boxes.back();
  const auto next =
      std::upper_bound(boxes.begin(), boxes.end(), timestamp_us,
                       [](int64_t t, const TrackBox& box) { return t < box.timestamp_us; });
  const TrackBox& b = *next;
  const TrackBox& a = *(next - 1);
  const double s = static_cast<double>(timestamp_us - a.timestamp_us) /
                   static_cast<double>(b.timestamp_us - a.timestamp_us);
  TrackBox box;
  box.timestamp_us = timestamp_us;
  box.center = a.center + s * (b.center - a.center);
  box.size = a.size + s * (b.size - a.size);
  box.rotation = Slerp(a.rotation, b.rotation, s);
  return box;
}

Rigid InstancePoseAt(const std::vector<TrackBox>& boxes, int64_t timestamp_us) {
  if (boxes.empty()) return Rigid{};
  return BoxPose(InterpolateBox(boxes, timestamp_us)) * BoxPose(boxes.front()).Inverse();
}

}  // namespace pf
