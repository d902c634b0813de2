// The stages of a reconstruction, named once (the paper's steps, in order),
// and the typed progress the engine reports through ReconOptions::progress.
//
//   options.progress = [](const ReconProgress& p) { Print(ProgressLine(p)); };
//   // "depth done in 1.2 s (8 of 8 views from LiDAR, ...)"
#ifndef POINTFORWARD_ENGINE_RECON_RECON_STAGES_H_
#define POINTFORWARD_ENGINE_RECON_RECON_STAGES_H_

#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace pf {

enum class ReconStage {
  kLoad,
  kDepth,
  kLift,
  kSceneGraph,
  kSample,
  kFuse,
  kDecode,
  kRefine,
  kOptimize
};

struct ReconStageInfo {
  ReconStage stage;
  const char* name;  // As progress, stage timings and report.json spell it: "scene_graph".
  // Share of a reconstruction's time, roughly (the default synth clip,
  // where the colour fit takes over half): what a progress fraction uses.
  double weight;
};

// Every stage in the order they run; kRefine runs only when the colour fit
// is on (RefinementOptions::iterations > 0), kOptimize only with
// optimisation steps (OptimizeOptions::steps > 0; its weight is for a
// default-sized run, and it reports a note about every 10 % of its steps).
const std::vector<ReconStageInfo>& ReconStages();

const char* ReconStageName(ReconStage stage);

// One report of the engine's progress.
struct ReconProgress {
  enum class Kind {
    kStageDone,  // `stage` ended after `seconds`; `detail` says what it made.
    kNote,       // `detail` is a line for people (a warning, what is being loaded).
  };
  Kind kind = Kind::kNote;
  std::optional<ReconStage> stage;  // Unset for notes outside the stages (pf eval's).
  double seconds = 0;
  std::string detail;  // kStageDone: " (123 queries)" or ""; kNote: the line.
};

using ReconProgressFn = std::function<void(const ReconProgress&)>;

// The line `pf reconstruct` and `pf eval` print for `progress`: "sample done
// in 2.5 s (123 queries)", or a note's text.
std::string ProgressLine(const ReconProgress& progress);

// Reports a note to `fn` when it is set.
void ReportNote(const ReconProgressFn& fn, std::optional<ReconStage> stage, std::string line);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RECON_RECON_STAGES_H_
