// Chooses which frames of an imported clip are CONTEXT (reconstruction input)
// and which are TARGET (held out for evaluation).
//
// The paper's protocol: per camera, the frames at 0, 0.5, 1.0 and 1.5 s after
// the clip's first timestamp are context, the rest are targets. Real logs do
// not hit those instants exactly, so each camera's frame closest to each
// instant is taken when it is within 250 ms of it (ties go to the earlier
// frame); a camera with no frame that close to any instant (it starts late,
// or the log is sparse) still gets its frame nearest to the clip start.
// Other policies: every frame context, or per camera alternating context and
// target frames in time order.
#ifndef POINTFORWARD_ENGINE_IMPORTERS_FRAME_ROLES_H_
#define POINTFORWARD_ENGINE_IMPORTERS_FRAME_ROLES_H_

#include <string>

#include "absl/status/statusor.h"
#include "pointforward/v1/clip.pb.h"

namespace pf {

enum class RolePolicy {
  kPaper,       // Context at 0, 0.5, 1.0, 1.5 s; the rest targets.
  kAllContext,  // Every frame is context.
  kAlternate,   // Per camera, in time order: even index context, odd target.
};

// Parses "paper", "all-context" or "alternate"; INVALID_ARGUMENT naming
// --roles otherwise.
absl::StatusOr<RolePolicy> ParseRolePolicy(const std::string& text);

// Sets the role of every frame of `clip` by `policy`.
void AssignRoles(RolePolicy policy, pointforward::v1::Clip* clip);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_IMPORTERS_FRAME_ROLES_H_
