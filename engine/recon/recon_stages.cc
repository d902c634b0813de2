// The stage list and progress lines: see recon_stages.h.
#include "engine/recon/recon_stages.h"

#include <utility>

#include "absl/strings/str_cat.h"

namespace pf {

const std::vector<ReconStageInfo>& ReconStages() {
  static const std::vector<ReconStageInfo> stages = {
      {ReconStage::kLoad, "load", 0.05},        {ReconStage::kDepth, "depth", 0.03},
      {ReconStage::kLift, "lift", 0.05},        {ReconStage::kSceneGraph, "scene_graph", 0.07},
      {ReconStage::kSample, "sample", 0.07},    {ReconStage::kFuse, "fuse", 0.05},
      {ReconStage::kDecode, "decode", 0.03},    {ReconStage::kRefine, "refine", 0.55},
      {ReconStage::kOptimize, "optimize", 1.0},
  };
  return stages;
}

const char* ReconStageName(ReconStage stage) {
  for (const ReconStageInfo& info : ReconStages()) {
    if (info.stage == stage) return info.name;
  }
  return "?";
}

std::string ProgressLine(const ReconProgress& progress) {
  if (progress.kind == ReconProgress::Kind::kNote || !progress.stage.has_value()) {
    return progress.detail;
  }
  return absl::StrCat(ReconStageName(*progress.stage), " done in ", progress.seconds, " s",
                      progress.detail);
}

void ReportNote(const ReconProgressFn& fn, std::optional<ReconStage> stage, std::string line) {
  if (!fn) return;
  ReconProgress note;
  note.kind = ReconProgress::Kind::kNote;
  note.stage = stage;
  note.detail = std::move(line);
  fn(note);
}

}  // namespace pf
