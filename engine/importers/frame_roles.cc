// Role assignment: nearest frame per camera to each context instant, every
// frame, or every other frame per camera.
#include "engine/importers/frame_roles.h"

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <limits>
#include <map>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"

namespace pf {
namespace {

constexpr int64_t kContextInstantsUs[] = {0, 500000, 1000000, 1500000};
// A frame stands for an instant only if it is this close to it (half the
// spacing of the instants), so a 1 Hz log does not turn every frame into
// context.
constexpr int64_t kInstantToleranceUs = 250000;

// Returns the index (among `indices`) of the frame nearest in time to
// `instant`; ties go to the earlier frame.
int NearestFrame(const pointforward::v1::Clip& clip, const std::vector<int>& indices,
                 int64_t instant) {
  int best = indices.front();
  for (int i : indices) {
    const int64_t t = clip.frames(i).timestamp_us(), best_t = clip.frames(best).timestamp_us();
    const int64_t d = std::llabs(t - instant), best_d = std::llabs(best_t - instant);
    if (d < best_d || (d == best_d && t < best_t)) best = i;
  }
  return best;
}

}  // namespace

absl::StatusOr<RolePolicy> ParseRolePolicy(const std::string& text) {
  if (text == "paper") return RolePolicy::kPaper;
  if (text == "all-context") return RolePolicy::kAllContext;
  if (text == "alternate") return RolePolicy::kAlternate;
  return absl::InvalidArgumentError(
      absl::StrCat("--roles: '", text, "' is not one of paper, all-context, alternate"));
}

void AssignRoles(RolePolicy policy, pointforward::v1::Clip* clip) {
  using pointforward::v1::Frame;
  if (clip->frames().empty()) return;
  if (policy == RolePolicy::kAllContext) {
    for (Frame& f : *clip->mutable_frames()) f.set_role(Frame::CONTEXT);
    return;
  }
  int64_t start = std::numeric_limits<int64_t>::max();
  std::map<std::string, std::vector<int>> by_camera;
  for (int i = 0; i < clip->frames_size(); ++i) {
    start = std::min(start, clip->frames(i).timestamp_us());
    by_camera[clip->frames(i).camera()].push_back(i);
    clip->mutable_frames(i)->set_role(Frame::TARGET);
  }
  if (policy == RolePolicy::kAlternate) {
    for (auto& [camera, indices] : by_camera) {
      std::stable_sort(indices.begin(), indices.end(), [&](int a, int b) {
        return clip->frames(a).timestamp_us() < clip->frames(b).timestamp_us();
      });
      for (size_t k = 0; k < indices.size(); k += 2) {
        clip->mutable_frames(indices[k])->set_role(Frame::CONTEXT);
      }
    }
    return;
  }
  for (const auto& [camera, indices] : by_camera) {
    bool any = false;
    for (int64_t offset : kContextInstantsUs) {
      const int best = NearestFrame(*clip, indices, start + offset);
      if (std::llabs(clip->frames(best).timestamp_us() - (start + offset)) <= kInstantToleranceUs) {
        clip->mutable_frames(best)->set_role(Frame::CONTEXT);
        any = true;
      }
    }
    // A camera that starts late still gets one context frame.
    if (!any) clip->mutable_frames(NearestFrame(*clip, indices, start))->set_role(Frame::CONTEXT);
  }
}

}  // namespace pf
