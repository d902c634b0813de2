// pf depth-eval CLIP.json [--hide half|top] [--top-share F] [--json FILE]
//               [--completion nearest|ip-basic] [--no-ground-fill] [--no-facades]
//               [--no-stereo]
//               [--working-space srgb|linear] [--allow-outside-paths]
// Hides a part of the clip's LiDAR (and sparse depth maps) from the depth
// stage and measures each method's dense depth at the hidden points
// (engine/recon/depth_holdout.h). Progress to stderr; a table to
// stdout; --json writes the figures.
#include <cstdio>
#include <set>
#include <string>
#include <vector>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "client/commands.h"
#include "common/command_line.h"
#include "common/file_util.h"
#include "common/status_macros.h"
#include "engine/clip/clip_io.h"
#include "engine/clip/clip_validator.h"
#include "engine/recon/depth_holdout.h"
#include "engine/recon/recon_option_table.h"
#include "engine/recon/recon_options.h"
#include "nlohmann/json.hpp"

namespace pf {
namespace {

constexpr char kDepthEvalHelp[] =
    R"(usage: pf depth-eval CLIP.json [--hide half|top] [--top-share F] [--json FILE]
                     [--completion nearest|ip-basic] [--no-ground-fill] [--no-facades]
                     [--no-stereo] [--working-space srgb|linear] [--allow-outside-paths]

Measures the dense depth of the clip's CONTEXT views where the clip measured
depth that the depth stage was not given. A part of every LiDAR sweep (and of
every sparse depth map) is hidden; each method completes the rest; the hidden
points a camera sees (the nearest point in their pixel, in pixels no kept point
falls in, ego pixels left out) are the truth:
  --hide half       a random half of the points (fixed seed; the default)
  --hide top        the highest share of them by elevation above the sensor's
                    level plane (--top-share, default 0.25): above the kept
                    top beams, where facades continue the measured walls
Methods, on the same kept points:
  nearest   each pixel the nearest kept measurement's depth, within the
            completion radius (LiDAR completion alone)
  ipBasic   IP-Basic with its upward extension (pf eval's warp baseline)
  ours      the reconstruction's depth stage with the flags given: completion,
            ground plane, facades, stereo (the plane sweep, the depth
            below continued up and the gaps enclosed by known depth);
            pixels left to the far layer are missing
Per method: points (hidden points with a depth), coverage (their share), AbsRel
(mean |depth - truth| / truth), RMSE (m), within5 (share within 5 %), over its
own points and over the points every method covers ("common").

  --json FILE   {"clip", "hide", "topShare", "views", "hiddenPoints",
                "keptMeasurements", "facadePixels", "stereoPixels", "upwardPixels",
                "enclosedPixels", "groundPixels", "seconds",
                "methods": {"nearest"|"ipBasic"|"ours": {"points", "missing",
                "coverage", "absRel", "rmse", "within5", "common": {"points",
                "absRel", "rmse", "within5"}}}}

example:
  pf depth-eval clip.json --hide top --json depth.json
)";

// The share of held-out points where the method has a depth.
double Coverage(const DepthErrors& e) {
  return e.points + e.missing > 0 ? double(e.points) / (e.points + e.missing) : 0.0;
}

nlohmann::ordered_json ErrorsJson(const DepthErrors& e, bool with_coverage) {
  nlohmann::ordered_json j;
  j["points"] = e.points;
  if (with_coverage) {
    j["missing"] = e.missing;
    j["coverage"] = Coverage(e);
  }
  j["absRel"] = e.abs_rel;
  j["rmse"] = e.rmse;
  j["within5"] = e.within_5pct;
  return j;
}

absl::Status DepthEvalCommand(const CommandLine& cl) {
  if (cl.positional().size() != 1) {
    return absl::InvalidArgumentError(
        "usage: pf depth-eval CLIP.json [--hide half|top] [--top-share F] [--json FILE] "
        "(pf depth-eval --help for more)");
  }
  ASSIGN_OR_RETURN(ReconOptions options, ReconOptionsFromFlags(cl));
  HoldOutOptions hold_out;
  ASSIGN_OR_RETURN(hold_out.mode, ParseHoldOutMode(cl.Get("hide", "half")));
  if (cl.Has("top-share")) {
    if (!absl::SimpleAtod(cl.Get("top-share"), &hold_out.top_share) ||
        !(hold_out.top_share > 0 && hold_out.top_share < 1)) {
      return absl::InvalidArgumentError(absl::StrCat(
          "--top-share: '", cl.Get("top-share"), "' is not a share between 0 and 1, e.g. 0.25"));
    }
  }
  if (cl.Has("json")) RETURN_IF_ERROR(CheckOutputFilePath("--json", cl.Get("json")));
  ValidateOptions validate;
  validate.allow_outside_paths = options.allow_outside_paths;
  const std::string clip_path = cl.positional()[0];
  ASSIGN_OR_RETURN(const LoadedClip loaded, LoadValidClip(clip_path, validate));
  std::fprintf(stderr, "pf depth-eval: loading the CONTEXT frames\n");
  ASSIGN_OR_RETURN(ReconInputs inputs, LoadReconInputs(loaded, options));
  std::fprintf(stderr, "pf depth-eval: hiding %s of the measurements of %zu views; depth stage\n",
               hold_out.mode == HoldOutOptions::Mode::kHalf
                   ? "a random half"
                   : absl::StrCat("the top ", hold_out.top_share).c_str(),
               inputs.views.size());
  ASSIGN_OR_RETURN(const DepthHoldOutReport report,
                   EvaluateDepthHoldOut(std::move(inputs), options.completion, hold_out));

  std::printf("%s: %lld hidden points in sight of %d views (--hide %s), %lld kept, %.1f s\n",
              clip_path.c_str(), static_cast<long long>(report.hidden_points), report.views,
              HoldOutModeName(hold_out.mode), static_cast<long long>(report.kept_measurements),
              report.seconds);
  std::printf("  %-8s %9s %9s %8s %8s %8s | common: %8s %8s %8s\n", "method", "points", "coverage",
              "AbsRel", "RMSE m", "within5", "AbsRel", "RMSE m", "within5");
  nlohmann::ordered_json methods;
  for (const DepthHoldOutMethod& method : report.methods) {
    const DepthErrors all = method.all.Mean(), common = method.common.Mean();
    std::printf("  %-8s %9lld %9.3f %8.4f %8.3f %8.3f | common: %8.4f %8.3f %8.3f\n",
                method.name.c_str(), static_cast<long long>(all.points), Coverage(all), all.abs_rel,
                all.rmse, all.within_5pct, common.abs_rel, common.rmse, common.within_5pct);
    nlohmann::ordered_json j = ErrorsJson(all, true);
    j["common"] = ErrorsJson(common, false);
    methods[method.name] = j;
  }
  std::printf(
      "  ours: %lld pixels from the ground plane, %lld from facades, %lld from stereo, %lld from "
      "the depth below continued up, %lld in gaps enclosed by known depth\n",
      static_cast<long long>(report.ground_pixels), static_cast<long long>(report.facade_pixels),
      static_cast<long long>(report.stereo_pixels), static_cast<long long>(report.upward_pixels),
      static_cast<long long>(report.enclosed_pixels));
  if (cl.Has("json")) {
    nlohmann::ordered_json j;
    j["clip"] = clip_path;
    j["hide"] = HoldOutModeName(hold_out.mode);
    j["topShare"] = hold_out.top_share;
    j["views"] = report.views;
    j["hiddenPoints"] = report.hidden_points;
    j["keptMeasurements"] = report.kept_measurements;
    j["facadePixels"] = report.facade_pixels;
    j["stereoPixels"] = report.stereo_pixels;
    j["upwardPixels"] = report.upward_pixels;
    j["enclosedPixels"] = report.enclosed_pixels;
    j["groundPixels"] = report.ground_pixels;
    j["seconds"] = report.seconds;
    j["methods"] = methods;
    RETURN_IF_ERROR(WriteFileAtomic(cl.Get("json"), j.dump(2) + "\n"));
  }
  return absl::OkStatus();
}

}  // namespace

int RunDepthEval(const std::vector<std::string>& args) {
  std::set<std::string> value_flags = ReconValueFlags();
  value_flags.insert({"hide", "top-share", "json"});
  std::set<std::string> bool_flags = ReconSwitchFlags();
  bool_flags.insert({"help", "allow-outside-paths"});
  absl::StatusOr<CommandLine> cl = CommandLine::Parse(args, value_flags, bool_flags);
  if (!cl.ok()) return ReportError("depth-eval", cl.status());
  if (cl->Has("help")) {
    std::fputs(kDepthEvalHelp, stdout);
    return kExitOk;
  }
  const absl::Status status = DepthEvalCommand(*cl);
  return status.ok() ? kExitOk : ReportError("depth-eval", status);
}

}  // namespace pf
