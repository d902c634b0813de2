// pf synth: writes a procedural driving clip with exact ground truth, and
// `pf synth render` ray-casts the true images and depths of such a clip at
// any requested views. The work is in engine/synth/.
#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "client/commands.h"
#include "common/command_line.h"
#include "common/elapsed.h"
#include "common/file_util.h"
#include "common/status_macros.h"
#include "engine/synth/synth_clip_writer.h"
#include "engine/synth/synth_params.h"
#include "engine/synth/synth_view_renderer.h"

namespace pf {
namespace {

// Reads an integer flag into `out` when given.
absl::Status IntFlag(const CommandLine& cl, const std::string& name, int* out) {
  ASSIGN_OR_RETURN(int64_t value, cl.GetInt(name, *out));
  if (value < -(int64_t{1} << 30) || value > (int64_t{1} << 30)) {
    return absl::InvalidArgumentError(absl::StrCat("--", name, ": out of range"));
  }
  *out = static_cast<int>(value);
  return absl::OkStatus();
}

// Returns `status` with its message prefixed by "--" when it names an
// option (the options are named as the flags are).
absl::Status AsFlagError(const absl::Status& status) {
  if (status.ok() || !absl::IsInvalidArgument(status)) return status;
  return absl::InvalidArgumentError(absl::StrCat("--", status.message()));
}

absl::Status Synth(const std::vector<std::string>& args) {
  ASSIGN_OR_RETURN(CommandLine cl,
                   CommandLine::Parse(args, {"out", "seed", "cameras", "frames", "width", "height",
                                             "antialias", "lens"}));
  if (!cl.positional().empty()) {
    return absl::InvalidArgumentError(
        absl::StrCat("unexpected argument '", cl.positional().front(), "'"));
  }
  const std::string out = cl.Get("out");
  if (out.empty()) return absl::InvalidArgumentError("--out: required (the clip directory)");
  RETURN_IF_ERROR(CheckOutputDirPath("--out", out));
  SynthOptions options;
  ASSIGN_OR_RETURN(int64_t seed, cl.GetInt("seed", 1));
  if (seed < 0) return absl::InvalidArgumentError("--seed: must not be negative");
  options.seed = static_cast<uint64_t>(seed);
  RETURN_IF_ERROR(IntFlag(cl, "cameras", &options.num_cameras));
  RETURN_IF_ERROR(IntFlag(cl, "frames", &options.num_frames));
  RETURN_IF_ERROR(cl.RequireBoth("width", "height"));
  RETURN_IF_ERROR(IntFlag(cl, "width", &options.width));
  RETURN_IF_ERROR(IntFlag(cl, "height", &options.height));
  RETURN_IF_ERROR(IntFlag(cl, "antialias", &options.antialias));
  if (cl.Has("lens")) {
    const absl::StatusOr<SynthLens> lens = SynthLensFromName(cl.Get("lens"));
    if (!lens.ok()) return AsFlagError(lens.status());
    options.lens = *lens;
  }
  RETURN_IF_ERROR(AsFlagError(ValidateSynthOptions(options)));

  const auto start = std::chrono::steady_clock::now();
  ASSIGN_OR_RETURN(SynthClipSummary summary, WriteSynthClip(options, out));
  const double seconds = SecondsSince(start);
  std::fprintf(stderr,
               "pf synth: wrote %s/clip.json: %d cameras, %d frames (%d CONTEXT, %d TARGET), "
               "%d LiDAR sweeps (%lld points), %d instances in %.1f s\n",
               out.c_str(), summary.cameras, summary.frames, summary.context_frames,
               summary.target_frames, summary.lidar_sweeps,
               static_cast<long long>(summary.lidar_points), summary.instances, seconds);
  return absl::OkStatus();
}

absl::Status SynthRender(const std::vector<std::string>& args) {
  ASSIGN_OR_RETURN(CommandLine cl, CommandLine::Parse(args, {"clip", "cameras", "out"}));
  if (!cl.positional().empty()) {
    return absl::InvalidArgumentError(
        absl::StrCat("unexpected argument '", cl.positional().front(), "'"));
  }
  for (const char* flag : {"clip", "cameras", "out"}) {
    if (cl.Get(flag).empty()) {
      return absl::InvalidArgumentError(absl::StrCat("--", flag, ": required"));
    }
  }
  ASSIGN_OR_RETURN(std::vector<std::string> names,
                   RenderSynthViews(cl.Get("clip"), cl.Get("cameras"), cl.Get("out")));
  std::fprintf(stderr, "pf synth render: wrote %zu views (PNG and depth EXR) to %s\n", names.size(),
               cl.Get("out").c_str());
  return absl::OkStatus();
}

}  // namespace

int RunSynth(const std::vector<std::string>& args) {
  if (!args.empty() && args.front() == "render") {
    const absl::Status status = SynthRender({args.begin() + 1, args.end()});
    return status.ok() ? kExitOk : ReportError("synth render", status);
  }
  const absl::Status status = Synth(args);
  return status.ok() ? kExitOk : ReportError("synth", status);
}

}  // namespace pf
