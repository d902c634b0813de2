// pf_colour_fit_bench: how long the colour fit (colour_refinement.h) takes on
// a real reconstruction, part by part. Prints one JSON object.
//
//   pf_colour_fit_bench --clip CLIP.json --scene SCENE [--runs 5] [--iterations 16]
//                       [--parts weights,normal,fit]
//
// SCENE is what `pf reconstruct CLIP.json --out SCENE` wrote; the fit only
// needs its geometry, so refitting its refined colours costs what the first
// fit did. Three parts (--parts picks some), each timed --runs times after
// one warm-up run (min / median / max seconds):
// - "weights": ComputeCompositingWeights of every CONTEXT view, one after
//   another on this thread (the fit runs one view per pool worker);
// - "normal": one AccumulateNormal (A^T M A x, the bulk of an iteration) of
//   every view, one after another on this thread;
// - "fit": the whole RefineColours with --iterations, on the engine's pool.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <random>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "common/command_line.h"
#include "common/elapsed.h"
#include "common/memory_reuse.h"
#include "common/status_macros.h"
#include "common/thread_pool.h"
#include "engine/clip/clip_io.h"
#include "engine/recon/colour_refinement.h"
#include "engine/recon/reconstruction.h"
#include "engine/render/compositing_weights.h"
#include "engine/render/scene_file.h"

namespace pf {
namespace {

// Runs `part` once to warm up, then `runs` times; min / median / max seconds
// (null for 0 runs).
template <typename Part>
absl::StatusOr<nlohmann::json> TimeRuns(int runs, const Part& part) {
  RETURN_IF_ERROR(part());
  if (runs == 0) return nlohmann::json();  // Run once for its result only.
  std::vector<double> seconds;
  for (int r = 0; r < runs; ++r) {
    const auto start = std::chrono::steady_clock::now();
    RETURN_IF_ERROR(part());
    seconds.push_back(SecondsSince(start));
  }
  std::sort(seconds.begin(), seconds.end());
  return nlohmann::json{
      {"min", seconds.front()}, {"median", seconds[seconds.size() / 2]}, {"max", seconds.back()}};
}

absl::Status Run(const std::vector<std::string>& args) {
  ASSIGN_OR_RETURN(CommandLine cl,
                   CommandLine::Parse(args, {"clip", "scene", "runs", "iterations", "parts"}));
  if (!cl.Has("clip") || !cl.Has("scene")) {
    return absl::InvalidArgumentError("--clip and --scene are required");
  }
  ASSIGN_OR_RETURN(int64_t runs, cl.GetInt("runs", 5));
  ASSIGN_OR_RETURN(int64_t iterations, cl.GetInt("iterations", RefinementOptions{}.iterations));
  if (runs < 1 || runs > 100) {
    return absl::InvalidArgumentError(absl::StrCat("--runs: 1 to 100, got ", runs));
  }
  if (iterations < 1 || iterations > 1000) {
    return absl::InvalidArgumentError(absl::StrCat("--iterations: 1 to 1000, got ", iterations));
  }
  std::vector<std::string> parts = cl.GetList("parts");
  if (parts.empty()) parts = {"weights", "normal", "fit"};
  for (const std::string& part : parts) {
    if (part != "weights" && part != "normal" && part != "fit") {
      return absl::InvalidArgumentError(
          absl::StrCat("--parts: unknown part '", part, "' (expected weights, normal or fit)"));
    }
  }
  auto wants = [&](const std::string& part) {
    return std::find(parts.begin(), parts.end(), part) != parts.end();
  };
  ASSIGN_OR_RETURN(LoadedClip clip, LoadClip(cl.Get("clip")));
  ASSIGN_OR_RETURN(GaussianScene scene, LoadScene(cl.Get("scene")));
  ReconOptions load_options;
  load_options.allow_outside_paths = true;
  load_options.colour_encoding = scene.colour_encoding;  // The fit's colours are the scene's.
  ASSIGN_OR_RETURN(ReconInputs inputs, LoadReconInputs(clip, load_options));

  RefinementOptions options;
  options.iterations = static_cast<int>(iterations);
  options.colour_gradients = !scene.colour_gradients.empty();
  WeightOptions weight_options;
  weight_options.min_weight = options.min_weight;
  weight_options.local_coords = options.colour_gradients;
  weight_options.omitted_colours = true;  // As the fit records them.

  nlohmann::json report = {{"views", inputs.views.size()},
                           {"gaussians", scene.size()},
                           {"colourGradients", options.colour_gradients},
                           {"iterations", iterations},
                           {"runs", runs},
                           {"poolWorkers", DefaultThreadPool().num_threads()}};
  if (wants("weights") || wants("normal")) {
    // Freed at the end of the block: the fit records its own.
    std::vector<CompositingWeights> weights(inputs.views.size());
    int64_t entries = 0;
    ASSIGN_OR_RETURN(nlohmann::json weights_seconds,
                     TimeRuns(wants("weights") ? static_cast<int>(runs) : 0, [&]() {
                       entries = 0;
                       for (size_t v = 0; v < inputs.views.size(); ++v) {
                         const ContextView& view = inputs.views[v];
                         ASSIGN_OR_RETURN(
                             weights[v],
                             ComputeCompositingWeights(scene, {view.camera, view.world_from_camera},
                                                       view.timestamp_us, weight_options));
                         entries += static_cast<int64_t>(weights[v].entries());
                       }
                       return absl::OkStatus();
                     }));

    report["entries"] = entries;
    if (wants("weights")) report["weightsSeconds"] = weights_seconds;
    if (wants("normal")) {
      const int per = options.colour_gradients ? 9 : 3;
      std::mt19937 random(3);
      std::uniform_real_distribution<float> unit(0.f, 1.f);
      std::vector<std::vector<float>> x(weights.size()), out(weights.size());
      std::vector<std::vector<uint8_t>> masks(weights.size());
      for (size_t v = 0; v < weights.size(); ++v) {
        x[v].resize(per * weights[v].gaussians.size());
        for (float& value : x[v]) value = unit(random);
        masks[v].resize(weights[v].alpha.size());
        for (size_t p = 0; p < masks[v].size(); ++p)
          masks[v][p] = weights[v].alpha[p] >= options.min_alpha;
      }
      ASSIGN_OR_RETURN(report["normalSeconds"], TimeRuns(static_cast<int>(runs), [&]() {
                         for (size_t v = 0; v < weights.size(); ++v) {
                           out[v].assign(x[v].size(), 0.f);
                           AccumulateNormal(weights[v], masks[v], x[v].data(), out[v].data());
                         }
                         return absl::OkStatus();
                       }));
    }
  }

  if (wants("fit")) {
    ASSIGN_OR_RETURN(report["fitSeconds"], TimeRuns(static_cast<int>(runs), [&]() {
                       GaussianScene copy = scene;
                       return RefineColours(inputs.views, options, &copy).status();
                     }));
  }
  std::printf("%s\n", report.dump().c_str());
  return absl::OkStatus();
}

}  // namespace
}  // namespace pf

int main(int argc, char** argv) {
  pf::KeepFreedMemoryForReuse();  // As pf and pf-worker do (common/memory_reuse.h).
  return pf::ExitStatusFor("pf_colour_fit_bench",
                           pf::Run(std::vector<std::string>(argv + 1, argv + argc)));
}
