// pf import waymo|dgp|pandaset: turns a driving log into a clip directory
// and prints one summary line (warnings, if any, go to stderr).
//
//   pf import waymo SEGMENT.tfrecord --out DIR [--cameras FRONT,FRONT_LEFT]
//       [--start-us T --duration-us D] [--roles paper|all-context|alternate]
//   pf import dgp SCENE_DIR --out DIR [--cameras CAMERA_01,...] [...same]
//   pf import pandaset SEQ_DIR --out DIR [--cameras front_camera,...]
//       [--frames A:B] [--scale S] [--roles ...]
//   any of them [--lidar-as-depth-maps]: the LiDAR written as a sparse depth
//       map per frame instead of sweeps
#include <cstdio>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "client/commands.h"
#include "common/command_line.h"
#include "common/file_util.h"
#include "common/status_macros.h"
#include "engine/clip/clip_validator.h"
#include "engine/image/image_io.h"
#include "engine/importers/clip_output.h"
#include "engine/importers/dgp_importer.h"
#include "engine/importers/pandaset_importer.h"
#include "engine/importers/waymo_importer.h"
#include "engine/recon/context_views.h"
#include "engine/recon/view_depth.h"
#include "pointforward/v1/clip.pb.h"

namespace pf {
namespace {

constexpr char kImportUsage[] =
    "usage: pf import waymo SEGMENT.tfrecord --out DIR [--cameras A,B] "
    "[--start-us T] [--duration-us D] [--roles paper|all-context|alternate]\n"
    "       pf import dgp SCENE_DIR --out DIR [--cameras A,B] [--start-us T] "
    "[--duration-us D] [--roles paper|all-context|alternate]\n"
    "       pf import pandaset SEQ_DIR --out DIR [--cameras A,B] [--frames A:B] "
    "[--scale S] [--roles paper|all-context|alternate]\n"
    "       any of them [--lidar-as-depth-maps]\n"
    "T and D are microseconds from the log's first timestamp; --frames A:B takes "
    "PandaSet frames A to B-1; 0 < S <= 1 resizes the images. --lidar-as-depth-maps "
    "writes each frame's LiDAR (the nearest sweep, moving boxes' points moved to the "
    "frame's time) as a sparse depth map, depth/<camera>_<timestampUs>.exr, and "
    "leaves the sweeps out of the clip: a clip as rigs that give depth maps write it.";

// Returns the directory of the running binary (from /proc/self/exe).
std::string ExecutableDir() {
  std::error_code ec;
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  return ec ? std::string(".") : exe.parent_path().string();
}

absl::StatusOr<PandasetOptions> ParsePandasetOptions(const CommandLine& cl) {
  PandasetOptions options;
  if (cl.Has("frames")) {
    ASSIGN_OR_RETURN(options.frames, ParseFrameRange(cl.Get("frames")));
  }
  ASSIGN_OR_RETURN(options.scale, cl.GetDouble("scale", 1.0));
  if (!(options.scale > 0 && options.scale <= 1)) {
    return absl::InvalidArgumentError(
        absl::StrCat("--scale: must be in (0, 1], got ", cl.Get("scale")));
  }
  // Installed beside pf: build/bin, or /usr/local/bin in the container image.
  options.module = (std::filesystem::path(ExecutableDir()) / kPandasetPicklesModule).string();
  return options;
}

absl::StatusOr<ImportOptions> ParseOptions(const CommandLine& cl) {
  ImportOptions options;
  options.out_dir = cl.Get("out");
  if (options.out_dir.empty()) return absl::InvalidArgumentError("--out DIR is required");
  RETURN_IF_ERROR(CheckOutputDirPath("--out", options.out_dir));
  options.cameras = cl.GetList("cameras");
  ASSIGN_OR_RETURN(options.start_us, cl.GetInt("start-us", 0));
  if (options.start_us < 0) return absl::InvalidArgumentError("--start-us must be >= 0");
  if (cl.Has("duration-us")) {
    ASSIGN_OR_RETURN(int64_t duration, cl.GetInt("duration-us", 0));
    if (duration <= 0) return absl::InvalidArgumentError("--duration-us must be positive");
    options.duration_us = duration;
  }
  ASSIGN_OR_RETURN(options.roles, ParseRolePolicy(cl.Get("roles", "paper")));
  return options;
}

// Replaces the LiDAR sweeps of the clip at `manifest_path` by a sparse depth
// map per frame (--lidar-as-depth-maps). Frames that have a depth map keep it.
// Returns the clip written.
absl::StatusOr<pointforward::v1::Clip> WriteLidarAsDepthMaps(const std::string& manifest_path) {
  ASSIGN_OR_RETURN(const LoadedClip loaded, LoadValidClip(manifest_path, {}));
  ASSIGN_OR_RETURN(const std::vector<LidarSweepData> sweeps, LoadLidarSweeps(loaded));
  if (sweeps.empty()) {
    return absl::FailedPreconditionError(absl::StrCat(
        "--lidar-as-depth-maps: the log gave the clip no LiDAR sweep to write as depth maps (",
        manifest_path, " is written without them)"));
  }
  ASSIGN_OR_RETURN(const std::vector<InstanceTrack> tracks, TracksFromClip(loaded.clip));
  std::map<std::string, CameraModel> cameras;
  for (const pointforward::v1::Camera& camera : loaded.clip.cameras()) {
    ASSIGN_OR_RETURN(CameraModel model, CameraModelFromProto(camera));
    cameras.emplace(camera.id(), model);
  }
  pointforward::v1::Clip clip = loaded.clip;
  RETURN_IF_ERROR(MakeDirs(absl::StrCat(loaded.dir, "/depth")));
  for (pointforward::v1::Frame& frame : *clip.mutable_frames()) {
    if (!frame.depth().empty()) continue;
    const int sweep = NearestSweep(sweeps, frame.timestamp_us());
    const ImageF depth = ProjectPoints(PointsAtTime(sweeps[sweep], tracks, frame.timestamp_us()),
                                       cameras.at(frame.camera()),
                                       Rigid::FromRowMajor(frame.world_from_camera().data()));
    const std::string relative =
        absl::StrCat("depth/", frame.camera(), "_", frame.timestamp_us(), ".exr");
    RETURN_IF_ERROR(WriteDepthExr(absl::StrCat(loaded.dir, "/", relative), depth));
    frame.set_depth(relative);
  }
  clip.clear_lidar();
  RETURN_IF_ERROR(WriteClipManifest(clip, loaded.dir).status());
  return clip;
}

absl::StatusOr<std::string> Import(const std::vector<std::string>& args) {
  ASSIGN_OR_RETURN(CommandLine cl, CommandLine::Parse(args,
                                                      {"out", "cameras", "start-us", "duration-us",
                                                       "roles", "frames", "scale"},
                                                      {"lidar-as-depth-maps"}));
  if (cl.positional().size() != 2) {
    return absl::InvalidArgumentError(absl::StrCat(
        cl.positional().empty() ? "expected a format (waymo, dgp or pandaset) and a source path"
                                : "expected a source path after the format",
        "\n", kImportUsage));
  }
  const std::string& format = cl.positional()[0];
  const std::string& source = cl.positional()[1];
  ASSIGN_OR_RETURN(ImportOptions options, ParseOptions(cl));
  const bool pandaset = format == "pandaset";
  for (const char* flag : {"frames", "scale"}) {
    if (!pandaset && cl.Has(flag)) {
      return absl::InvalidArgumentError(absl::StrCat("--", flag, " is for pandaset only"));
    }
  }
  for (const char* flag : {"start-us", "duration-us"}) {
    if (pandaset && cl.Has(flag)) {
      return absl::InvalidArgumentError(
          absl::StrCat("--", flag, " is not for pandaset: choose frames with --frames A:B"));
    }
  }
  ImportResult result;
  if (format == "waymo") {
    ASSIGN_OR_RETURN(result, ImportWaymo(source, options));
  } else if (format == "dgp") {
    ASSIGN_OR_RETURN(result, ImportDgp(source, options));
  } else if (pandaset) {
    ASSIGN_OR_RETURN(PandasetOptions pandaset_options, ParsePandasetOptions(cl));
    ASSIGN_OR_RETURN(result, ImportPandaset(source, options, pandaset_options));
  } else {
    return absl::InvalidArgumentError(
        absl::StrCat("unknown format '", format, "' (waymo, dgp or pandaset)\n", kImportUsage));
  }
  for (const std::string& warning : result.warnings) {
    std::fprintf(stderr, "pf import: warning: %s\n", warning.c_str());
  }
  if (cl.Has("lidar-as-depth-maps")) {
    ASSIGN_OR_RETURN(const pointforward::v1::Clip clip,
                     WriteLidarAsDepthMaps(result.manifest_path));
    return absl::StrCat(result.manifest_path, ": ", SummarizeClip(clip),
                        "; LiDAR written as a sparse depth map per frame (depth/)");
  }
  return absl::StrCat(result.manifest_path, ": ", SummarizeClip(result.clip));
}

}  // namespace

int RunImport(const std::vector<std::string>& args) {
  const absl::StatusOr<std::string> summary = Import(args);
  if (!summary.ok()) {
    // A corrupt or truncated log (DATA_LOSS) is bad input, not a failure here.
    const int code = ReportError("import", summary.status());
    return summary.status().code() == absl::StatusCode::kDataLoss ? kExitBadInput : code;
  }
  std::printf("%s\n", summary->c_str());
  return kExitOk;
}

}  // namespace pf
