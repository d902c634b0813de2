// PandaSet sequence -> clip: cameras and images, LiDAR sweeps, moving tracks.
#include "engine/importers/pandaset_importer.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <optional>
#include <set>
#include <thread>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "common/file_util.h"
#include "common/geometry.h"
#include "common/status_macros.h"
#include "common/subprocess.h"
#include "common/thread_pool.h"
#include "engine/image/image_io.h"
#include "engine/importers/jpeg_header.h"
#include "engine/importers/json_fields.h"
#include "engine/importers/npy.h"
#include "engine/importers/spinning_lidar_origin.h"
#include "pointforward/v1/clip.pb.h"

namespace pf {
namespace {

namespace fs = std::filesystem;
namespace v1 = pointforward::v1;

// pandaset_pickles.py's exit statuses.
constexpr int kPicklesBadInput = 2;
constexpr int kPicklesNoPandas = 3;
// Columns of the reader's LiDAR arrays: x, y, z, i, t, d.
constexpr int kLidarColumns = 6;
constexpr int kPandasetJpegQuality = 95;
// The id PandaSet writes when a cuboid has no sibling.
constexpr char kNoSibling[] = "-";

// Returns the frame number of a per-frame file ("30.jpg", "05.pkl.gz" with
// `suffix` ".jpg" / ".pkl.gz"); nullopt for other names.
std::optional<int> FrameNumberOf(const std::string& name, const std::string& suffix) {
  if (!absl::EndsWith(name, suffix) || name.size() == suffix.size()) return std::nullopt;
  int frame;
  if (!absl::SimpleAtoi(name.substr(0, name.size() - suffix.size()), &frame) || frame < 0) {
    return std::nullopt;
  }
  return frame;
}

// Reads {position {x, y, z}, heading {w, x, y, z}} (heading a unit quaternion).
absl::StatusOr<Rigid> PandasetPose(const Json& pose, const std::string& where) {
  return JsonPose(pose, {"heading", "w", "x", "y", "z", "position"}, where);
}

// The per-frame lists of a sensor directory: poses.json and timestamps.json,
// both indexed by frame number.
struct SensorTrack {
  std::string dir;
  Json poses, timestamps;

  static absl::StatusOr<SensorTrack> Load(const std::string& dir) {
    SensorTrack t{dir, {}, {}};
    ASSIGN_OR_RETURN(t.poses, LoadJson(dir + "/poses.json"));
    ASSIGN_OR_RETURN(t.timestamps, LoadJson(dir + "/timestamps.json"));
    for (const auto* list : {&t.poses, &t.timestamps}) {
      if (!list->is_array()) {
        return absl::InvalidArgumentError(absl::StrCat(
            dir, list == &t.poses ? "/poses.json" : "/timestamps.json", ": not an array"));
      }
    }
    return t;
  }

  absl::StatusOr<Rigid> Pose(int frame) const {
    const std::string where = absl::StrCat(dir, "/poses.json[", frame, "]");
    if (static_cast<size_t>(frame) >= poses.size()) {
      return absl::InvalidArgumentError(
          absl::StrCat(where, ": missing (the list has ", poses.size(), " entries)"));
    }
    return PandasetPose(poses[frame], where);
  }

  // The frame's time in integer microseconds (the file has float seconds).
  absl::StatusOr<int64_t> TimestampUs(int frame) const {
    const std::string where = absl::StrCat(dir, "/timestamps.json[", frame, "]");
    if (static_cast<size_t>(frame) >= timestamps.size()) {
      return absl::InvalidArgumentError(
          absl::StrCat(where, ": missing (the list has ", timestamps.size(), " entries)"));
    }
    const Json& t = timestamps[frame];
    if (!t.is_number() || !std::isfinite(t.get<double>())) {
      return absl::InvalidArgumentError(absl::StrCat(where, ": not a number"));
    }
    return std::llround(t.get<double>() * 1e6);
  }
};

// Removes a directory tree when it goes out of scope.
class RemoveOnExit {
 public:
  explicit RemoveOnExit(std::string dir) : dir_(std::move(dir)) {}
  ~RemoveOnExit() {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  RemoveOnExit(const RemoveOnExit&) = delete;
  RemoveOnExit& operator=(const RemoveOnExit&) = delete;

 private:
  std::string dir_;
};

// One image to write: copied as it is, or resized to the camera's size.
struct ImageJob {
  std::string source;
  std::string relative;
  int source_width, source_height;  // What every image of the camera measures.
  int width, height;                // The camera's size in the clip.
};

std::string FrameList(const std::vector<int>& frames) { return absl::StrJoin(frames, ", "); }

class PandasetImport {
 public:
  PandasetImport(std::string sequence_dir, const ImportOptions& options,
                 const PandasetOptions& pandaset)
      : dir_(std::move(sequence_dir)), options_(options), pandaset_(pandaset) {}

  absl::StatusOr<ImportResult> Run();

 private:
  absl::StatusOr<std::vector<std::string>> SelectCameras();
  absl::Status AddCamera(const std::string& name, std::vector<ImageJob>* jobs);
  absl::Status WriteImages(const std::vector<ImageJob>& jobs);
  absl::Status CheckPickleReader(const absl::StatusOr<ProcessResult>& run);
  absl::Status LocateLidarHead(const std::string& pickles, const SensorTrack& lidar);
  absl::Status AddLidar(const std::string& pickles, int frame, const SensorTrack& lidar);
  absl::Status AddCuboids(const std::string& pickles, int frame, const SensorTrack& lidar);

  std::string dir_;
  const ImportOptions& options_;
  const PandasetOptions& pandaset_;
  std::set<int> frames_;  // Frames with an image in the range, all cameras.
  std::map<std::string, v1::Instance> instances_;
  std::vector<int> frames_without_lidar_, frames_without_cuboids_;
  // The Pandar64's head in the frame of lidar/poses.json (LocateLidarHead).
  LidarOriginEstimate lidar_head_;
  v1::Clip clip_;
};

absl::StatusOr<std::vector<std::string>> PandasetImport::SelectCameras() {
  std::error_code ec;
  if (!fs::is_directory(dir_, ec)) {
    return absl::NotFoundError(absl::StrCat(dir_, ": no such sequence directory"));
  }
  const std::string camera_dir = dir_ + "/camera";
  std::set<std::string> have;
  for (const auto& entry : fs::directory_iterator(camera_dir, ec)) {
    if (entry.is_directory() && fs::exists(entry.path() / "intrinsics.json")) {
      have.insert(entry.path().filename().string());
    }
  }
  if (have.empty()) {
    return absl::NotFoundError(absl::StrCat(
        camera_dir, ": no camera directories (camera/<name>/intrinsics.json) in the sequence"));
  }
  for (const std::string& wanted : options_.cameras) {
    if (!have.count(wanted)) {
      return absl::InvalidArgumentError(absl::StrCat("--cameras ", wanted,
                                                     ": no such camera in the sequence (have ",
                                                     absl::StrJoin(have, ", "), ")"));
    }
  }
  if (options_.cameras.empty()) return std::vector<std::string>(have.begin(), have.end());
  return std::vector<std::string>(options_.cameras.begin(), options_.cameras.end());
}

absl::Status PandasetImport::AddCamera(const std::string& name, std::vector<ImageJob>* jobs) {
  const std::string camera_dir = absl::StrCat(dir_, "/camera/", name);
  std::map<int, std::string> images;  // Frame -> JPEG path, in the range.
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(camera_dir, ec)) {
    const std::optional<int> frame = FrameNumberOf(entry.path().filename().string(), ".jpg");
    if (frame && *frame >= pandaset_.frames.begin && *frame < pandaset_.frames.end) {
      images[*frame] = entry.path().string();
    }
  }
  if (images.empty()) return absl::OkStatus();

  const std::string intrinsics_path = camera_dir + "/intrinsics.json";
  ASSIGN_OR_RETURN(Json k, LoadJson(intrinsics_path));
  double fx, fy, cx, cy;
  ASSIGN_OR_RETURN(fx, JsonNumber(k, "fx", intrinsics_path));
  ASSIGN_OR_RETURN(fy, JsonNumber(k, "fy", intrinsics_path));
  ASSIGN_OR_RETURN(cx, JsonNumber(k, "cx", intrinsics_path));
  ASSIGN_OR_RETURN(cy, JsonNumber(k, "cy", intrinsics_path));
  if (fx <= 0 || fy <= 0) {
    return absl::InvalidArgumentError(
        absl::StrCat(intrinsics_path, ": fx and fy must be positive"));
  }
  ASSIGN_OR_RETURN(std::string first, ReadFileToString(images.begin()->second));
  ASSIGN_OR_RETURN(JpegSize size, ReadJpegSize(first, images.begin()->second));
  const int width = std::max(1, static_cast<int>(std::lround(size.width * pandaset_.scale)));
  const int height = std::max(1, static_cast<int>(std::lround(size.height * pandaset_.scale)));
  const double sx = static_cast<double>(width) / size.width;
  const double sy = static_cast<double>(height) / size.height;

  v1::Camera* camera = clip_.add_cameras();
  camera->set_id(name);
  camera->set_width(width);
  camera->set_height(height);
  // PandaSet puts pixel centres on integers, the manifest at +0.5; scaling
  // maps continuous coordinates (edges at 0 and W) by the size ratio.
  camera->mutable_intrinsics()->set_fx(fx * sx);
  camera->mutable_intrinsics()->set_fy(fy * sy);
  camera->mutable_intrinsics()->set_cx((cx + 0.5) * sx);
  camera->mutable_intrinsics()->set_cy((cy + 0.5) * sy);
  camera->mutable_distortion()->set_model(v1::Distortion::NONE);

  ASSIGN_OR_RETURN(SensorTrack track, SensorTrack::Load(camera_dir));
  for (const auto& [frame, path] : images) {
    ASSIGN_OR_RETURN(Rigid world_from_camera, track.Pose(frame));
    ASSIGN_OR_RETURN(int64_t timestamp, track.TimestampUs(frame));
    const std::string relative = absl::StrCat("images/", name, "_", timestamp, ".jpg");
    v1::Frame* f = clip_.add_frames();
    f->set_camera(name);
    f->set_timestamp_us(timestamp);
    f->set_image(relative);
    SetRowMajor(world_from_camera, f->mutable_world_from_camera());
    jobs->push_back({path, relative, size.width, size.height, width, height});
    frames_.insert(frame);
  }
  return absl::OkStatus();
}

absl::Status PandasetImport::WriteImages(const std::vector<ImageJob>& jobs) {
  std::vector<absl::Status> results(jobs.size());
  DefaultThreadPool().ParallelFor(
      0, static_cast<int64_t>(jobs.size()), 1, [&](int64_t b, int64_t e) {
        for (int64_t i = b; i < e; ++i) {
          const ImageJob& job = jobs[i];
          results[i] = [&]() -> absl::Status {
            ASSIGN_OR_RETURN(std::string bytes, ReadFileToString(job.source));
            ASSIGN_OR_RETURN(JpegSize size, ReadJpegSize(bytes, job.source));
            if (size.width != job.source_width || size.height != job.source_height) {
              return absl::InvalidArgumentError(
                  absl::StrCat(job.source, ": image is ", size.width, "x", size.height,
                               " but the camera's other ", "images are ", job.source_width, "x",
                               job.source_height));
            }
            const std::string out = (fs::path(options_.out_dir) / job.relative).string();
            if (job.width == job.source_width && job.height == job.source_height) {
              return WriteFileAtomic(out, bytes);
            }
            return ResizeImageFile(job.source, out, job.width, job.height, kPandasetJpegQuality);
          }();
        }
      });
  for (const absl::Status& s : results) RETURN_IF_ERROR(s);
  return absl::OkStatus();
}

absl::Status PandasetImport::CheckPickleReader(const absl::StatusOr<ProcessResult>& run) {
  constexpr char kInstall[] =
      "PandaSet's LiDAR and cuboids are pickled pandas DataFrames, read with Debian's python3 "
      "and python3-pandas: apt-get install python3-pandas";
  if (!run.ok()) {
    return absl::FailedPreconditionError(
        absl::StrCat(pandaset_.python, ": ", std::string(run.status().message()), "; ", kInstall));
  }
  const std::string message(absl::StripTrailingAsciiWhitespace(run->err));
  switch (run->exit_code) {
    case 0:
      return absl::OkStatus();
    case kPicklesNoPandas:
      return absl::FailedPreconditionError(absl::StrCat(message, "; ", kInstall));
    case kPicklesBadInput:
      return absl::InvalidArgumentError(message);
    default:
      return absl::InternalError(
          absl::StrCat(pandaset_.module, " failed (exit ", run->exit_code, "): ", message));
  }
}

// Reads the frame's converted sweep (x, y, z, i, t, d rows, world frame).
absl::StatusOr<std::optional<NpyArray>> ReadSweep(const std::string& pickles,
                                                  const std::string& dir, int frame) {
  const std::string npy_path = absl::StrCat(pickles, "/lidar/", frame, ".npy");
  if (!fs::exists(npy_path)) return std::optional<NpyArray>();
  const std::string label = absl::StrCat(dir, "/lidar: frame ", frame);
  ASSIGN_OR_RETURN(std::string bytes, ReadFileToString(npy_path));
  ASSIGN_OR_RETURN(NpyArray array, ParseNpy(bytes, label));
  if (array.shape.size() != 2 || array.shape[1] != kLidarColumns) {
    return absl::InvalidArgumentError(absl::StrCat(label, ": expected N x 6 points"));
  }
  return std::optional<NpyArray>(std::move(array));
}

// PandaSet's lidar/poses.json is not where the Pandar64's head is (on
// sequence 002 the head is 1.86 m above it and 0.7 m along its y axis:
// docs/IMPORTERS.md). Finds the head from the Pandar64's points (d = 0) of up
// to kHeadFrames frames spread over the range, in the pose's frame
// (EstimateSpinningLidarOrigin); the sweeps are then written with the head
// as their sensor's origin.
constexpr size_t kHeadFrames = 6;
absl::Status PandasetImport::LocateLidarHead(const std::string& pickles, const SensorTrack& lidar) {
  const std::vector<int> frames(frames_.begin(), frames_.end());
  const size_t count = std::min(kHeadFrames, frames.size());
  std::vector<std::vector<FiredPoint>> sweeps;
  for (size_t k = 0; k < count; ++k) {
    const int frame = frames[k * frames.size() / count];
    ASSIGN_OR_RETURN(std::optional<NpyArray> array, ReadSweep(pickles, dir_, frame));
    if (!array.has_value()) continue;
    ASSIGN_OR_RETURN(const Rigid world_from_pose, lidar.Pose(frame));
    const Rigid pose_from_world = world_from_pose.Inverse();
    std::vector<FiredPoint>& sweep = sweeps.emplace_back();
    for (int64_t i = 0; i < array->shape[0]; ++i) {
      const double* row = &array->data[i * kLidarColumns];
      if (row[5] != 0) continue;  // The PandarGT.
      sweep.push_back({pose_from_world * Vec3{row[0], row[1], row[2]}, row[4]});
    }
  }
  lidar_head_ = EstimateSpinningLidarOrigin(sweeps);
  return absl::OkStatus();
}

absl::Status PandasetImport::AddLidar(const std::string& pickles, int frame,
                                      const SensorTrack& lidar) {
  ASSIGN_OR_RETURN(std::optional<NpyArray> sweep, ReadSweep(pickles, dir_, frame));
  if (!sweep.has_value()) {
    frames_without_lidar_.push_back(frame);
    return absl::OkStatus();
  }
  const NpyArray& array = *sweep;
  ASSIGN_OR_RETURN(Rigid world_from_sensor, lidar.Pose(frame));
  // The sensor's origin at the head (the pose's axes kept).
  world_from_sensor.translation =
      world_from_sensor.translation + world_from_sensor.rotation * lidar_head_.centre;
  ASSIGN_OR_RETURN(int64_t timestamp, lidar.TimestampUs(frame));
  const Rigid sensor_from_world = world_from_sensor.Inverse();
  const int64_t n = array.shape[0];
  std::vector<float> points(static_cast<size_t>(n) * 4);
  for (int64_t i = 0; i < n; ++i) {
    const double* row = &array.data[i * kLidarColumns];  // x, y, z, i, t, d (world frame).
    const Vec3 p = sensor_from_world * Vec3{row[0], row[1], row[2]};
    points[4 * i + 0] = static_cast<float>(p.x);
    points[4 * i + 1] = static_cast<float>(p.y);
    points[4 * i + 2] = static_cast<float>(p.z);
    points[4 * i + 3] = static_cast<float>(row[3]);
  }
  return AddLidarSweep(points, options_.out_dir, absl::StrCat("lidar/lidar_", timestamp, ".bin"),
                       timestamp, world_from_sensor, &clip_);
}

absl::Status PandasetImport::AddCuboids(const std::string& pickles, int frame,
                                        const SensorTrack& lidar) {
  const std::string json_path = absl::StrCat(pickles, "/cuboids/", frame, ".json");
  if (!fs::exists(json_path)) {
    frames_without_cuboids_.push_back(frame);
    return absl::OkStatus();
  }
  ASSIGN_OR_RETURN(Json rows, LoadJson(json_path));
  const std::string file = absl::StrCat(dir_, "/annotations/cuboids: frame ", frame);
  if (!rows.is_array()) return absl::InvalidArgumentError(absl::StrCat(file, ": not a list"));
  ASSIGN_OR_RETURN(int64_t timestamp, lidar.TimestampUs(frame));

  // The Pandar64's boxes (sensor_id 0); a PandarGT box (sensor_id 1) whose
  // sibling is one of them is the same object listed twice. Sibling ids may
  // be cut short (the sample has 34-character ones), so a prefix matches.
  std::vector<std::string> pandar64;
  for (const Json& row : rows) {
    if (!row.is_object()) continue;
    const auto sensor = row.find("cuboids.sensor_id");
    const auto uuid = row.find("uuid");
    if (sensor != row.end() && sensor->is_number() && sensor->get<double>() == 0 &&
        uuid != row.end() && uuid->is_string()) {
      pandar64.push_back(uuid->get<std::string>());
    }
  }
  for (size_t r = 0; r < rows.size(); ++r) {
    const Json& row = rows[r];
    const std::string where = absl::StrCat(file, ": row ", r);
    ASSIGN_OR_RETURN(std::string uuid, JsonString(row, "uuid", where));
    ASSIGN_OR_RETURN(const Json* stationary, JsonMember(row, "stationary", where));
    if (!stationary->is_boolean()) {
      return absl::InvalidArgumentError(absl::StrCat(where, ".stationary: not a boolean"));
    }
    ASSIGN_OR_RETURN(double sensor, JsonNumber(row, "cuboids.sensor_id", where));
    if (sensor == 1) {
      ASSIGN_OR_RETURN(std::string sibling, JsonString(row, "cuboids.sibling_id", where));
      if (sibling != kNoSibling && !sibling.empty() &&
          std::any_of(pandar64.begin(), pandar64.end(),
                      [&](const std::string& id) { return absl::StartsWith(id, sibling); })) {
        continue;
      }
    }
    ASSIGN_OR_RETURN(std::string label, JsonString(row, "label", where));
    ASSIGN_OR_RETURN(double yaw, JsonNumber(row, "yaw", where));
    Vec3 center, dimensions;
    ASSIGN_OR_RETURN(center.x, JsonNumber(row, "position.x", where));
    ASSIGN_OR_RETURN(center.y, JsonNumber(row, "position.y", where));
    ASSIGN_OR_RETURN(center.z, JsonNumber(row, "position.z", where));
    ASSIGN_OR_RETURN(dimensions.x, JsonNumber(row, "dimensions.x", where));
    ASSIGN_OR_RETURN(dimensions.y, JsonNumber(row, "dimensions.y", where));
    ASSIGN_OR_RETURN(dimensions.z, JsonNumber(row, "dimensions.z", where));
    if (!(dimensions.x > 0 && dimensions.y > 0 && dimensions.z > 0)) {
      return absl::InvalidArgumentError(absl::StrCat(where, ": dimensions must be positive"));
    }
    v1::Instance& instance = instances_[uuid];
    if (!instance.boxes().empty() &&
        instance.boxes(instance.boxes_size() - 1).timestamp_us() == timestamp) {
      return absl::InvalidArgumentError(
          absl::StrCat(where, ": track ", uuid, " has two boxes in this frame"));
    }
    instance.set_id(uuid);
    instance.set_category(label);
    // The box's x axis in the world is (cos yaw, sin yaw, 0) with extent
    // dimensions.x (its width); the manifest's x is the length.
    const Rigid world_from_box{RotationZ(yaw + M_PI / 2), center};
    AddBox(timestamp, world_from_box, {dimensions.y, dimensions.x, dimensions.z}, &instance);
  }
  return absl::OkStatus();
}

absl::StatusOr<ImportResult> PandasetImport::Run() {
  if (!(pandaset_.scale > 0 && pandaset_.scale <= 1)) {
    return absl::InvalidArgumentError(
        absl::StrCat("--scale: must be in (0, 1], got ", pandaset_.scale));
  }
  ASSIGN_OR_RETURN(std::vector<std::string> cameras, SelectCameras());
  std::vector<ImageJob> jobs;
  for (const std::string& name : cameras) RETURN_IF_ERROR(AddCamera(name, &jobs));
  if (frames_.empty()) {
    return absl::InvalidArgumentError(absl::StrCat(
        dir_, ": no camera images in the selected cameras and frames (camera/<name>/NN.jpg)"));
  }
  ASSIGN_OR_RETURN(SensorTrack lidar, SensorTrack::Load(dir_ + "/lidar"));

  // The pickles are read by Python while the images are written.
  std::error_code ec;
  if (!fs::is_regular_file(pandaset_.module, ec)) {
    return absl::FailedPreconditionError(
        absl::StrCat("the PandaSet pickle reader '", pandaset_.module,
                     "' is missing (it is installed beside the pf binary)"));
  }
  const std::string pickles =
      (fs::path(options_.out_dir) / absl::StrCat(".pandaset_pickles_", ProcessToken())).string();
  RETURN_IF_ERROR(MakeDirs(pickles));
  RemoveOnExit remove_pickles(pickles);
  std::vector<std::string> argv = {pandaset_.python, pandaset_.module, dir_, pickles};
  for (int frame : frames_) argv.push_back(absl::StrCat(frame));
  absl::StatusOr<ProcessResult> reader = absl::UnknownError("not run");
  std::thread python([&] { reader = RunProcess(argv); });
  const absl::Status images = WriteImages(jobs);
  python.join();
  RETURN_IF_ERROR(images);
  RETURN_IF_ERROR(CheckPickleReader(reader));

  RETURN_IF_ERROR(LocateLidarHead(pickles, lidar));
  for (int frame : frames_) {
    RETURN_IF_ERROR(AddLidar(pickles, frame, lidar));
    RETURN_IF_ERROR(AddCuboids(pickles, frame, lidar));
  }
  for (auto& [id, instance] : instances_) *clip_.add_instances() = std::move(instance);
  clip_.set_name(fs::path(dir_).lexically_normal().filename().string());
  if (clip_.name().empty()) clip_.set_name(fs::path(dir_).parent_path().filename().string());
  AssignRoles(options_.roles, &clip_);

  ImportResult result;
  if (!frames_without_lidar_.empty()) {
    result.warnings.push_back(absl::StrCat("no lidar/NN.pkl.gz for frames ",
                                           FrameList(frames_without_lidar_),
                                           ": no LiDAR sweep imported for them"));
  }
  if (!frames_without_cuboids_.empty()) {
    result.warnings.push_back(absl::StrCat("no annotations/cuboids/NN.pkl.gz for frames ",
                                           FrameList(frames_without_cuboids_),
                                           ": no boxes imported for them"));
  }
  if (lidar_head_.reliable) {
    result.warnings.push_back(absl::StrFormat(
        "LiDAR sweeps placed at the Pandar64's head, (%.2f, %.2f, %.2f) m in the frame of "
        "lidar/poses.json, where its points put it (%d point pairs); the poses file's origin is "
        "not the sensor's",
        lidar_head_.centre.x, lidar_head_.centre.y, lidar_head_.centre.z, lidar_head_.pairs));
  } else if (clip_.lidar_size() > 0) {
    result.warnings.push_back(absl::StrCat(
        "the Pandar64's head could not be located from its points (", lidar_head_.pairs,
        " point pairs): the sweeps keep lidar/poses.json's origin, which on PandaSet lies about "
        "1.9 m below the head, so LiDAR rendered from them starts too low"));
  }
  ASSIGN_OR_RETURN(result.manifest_path, WriteClipManifest(clip_, options_.out_dir));
  result.clip = std::move(clip_);
  return result;
}

}  // namespace

absl::StatusOr<FrameRange> ParseFrameRange(const std::string& text) {
  const std::vector<std::string> parts = absl::StrSplit(text, ':');
  const auto bad = [&] {
    return absl::InvalidArgumentError(
        absl::StrCat("--frames: '", text, "' is not A:B (frame numbers, B excluded), A: or :B"));
  };
  if (parts.size() != 2 || (parts[0].empty() && parts[1].empty())) return bad();
  FrameRange range;
  if (!parts[0].empty() && (!absl::SimpleAtoi(parts[0], &range.begin) || range.begin < 0)) {
    return bad();
  }
  if (!parts[1].empty() && (!absl::SimpleAtoi(parts[1], &range.end) || range.end < 0)) {
    return bad();
  }
  if (range.end <= range.begin) {
    return absl::InvalidArgumentError(
        absl::StrCat("--frames: '", text, "' is empty (B must be greater than A)"));
  }
  return range;
}

absl::StatusOr<ImportResult> ImportPandaset(const std::string& sequence_dir,
                                            const ImportOptions& options,
                                            const PandasetOptions& pandaset) {
  PandasetImport import(sequence_dir, options, pandaset);
  return import.Run();
}

}  // namespace pf
