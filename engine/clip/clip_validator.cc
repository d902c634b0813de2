// Clip manifest validation. The manifest itself is checked in one pass in
// manifest order; the files it references are then opened in parallel on the
// default thread pool, and their problems are merged back in manifest order.
#include "engine/clip/clip_validator.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <map>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "common/file_util.h"
#include "common/geometry.h"
#include "common/thread_pool.h"
#include "engine/camera/camera_model.h"
#include "engine/image/image_io.h"
#include "pointforward/v1/clip.pb.h"

namespace pf {
namespace {

namespace fs = std::filesystem;
using pointforward::v1::Box;
using pointforward::v1::Camera;
using pointforward::v1::Clip;
using pointforward::v1::Distortion;
using pointforward::v1::Frame;
using pointforward::v1::Instance;
using pointforward::v1::LidarSweep;

// Bytes of one LiDAR record: float32 x, y, z, intensity.
constexpr int64_t kLidarRecordBytes = 16;

// Where a problem sits in the manifest, for ordering the report.
enum class Section { kCameras, kFrames, kLidar, kInstances };

std::string Indexed(const char* name, int index) { return absl::StrCat(name, "[", index, "]"); }

// Returns "WxH".
std::string SizeText(int width, int height) { return absl::StrCat(width, "x", height); }

// A referenced file to open, and what it must satisfy.
struct FileCheck {
  enum class Kind { kImage, kDepth, kLidar, kEgoMask };
  Kind kind = Kind::kImage;
  Section section = Section::kFrames;
  int item = 0;
  std::string field;               // e.g. "frames[3].image".
  std::string path;                // Resolved.
  const Camera* camera = nullptr;  // Expected size; null when unknown.
  std::vector<ClipProblem> problems;
};

// Runs one file check, filling `check->problems`.
void RunFileCheck(FileCheck* check) {
  auto add = [check](std::string message) {
    check->problems.push_back({check->field, std::move(message)});
  };
  auto check_size = [&](const char* what, int width, int height) {
    const Camera* camera = check->camera;
    if (camera == nullptr || camera->width() <= 0 || camera->height() <= 0) return;
    if (width != camera->width() || height != camera->height()) {
      add(absl::StrCat(what, " is ", SizeText(width, height), " but camera '", camera->id(),
                       "' is ", SizeText(camera->width(), camera->height())));
    }
  };
  switch (check->kind) {
    case FileCheck::Kind::kImage:
    case FileCheck::Kind::kEgoMask: {
      const bool is_mask = check->kind == FileCheck::Kind::kEgoMask;
      absl::StatusOr<ImageF> image = ReadImage(check->path);
      if (!image.ok()) {
        add(std::string(image.status().message()));
        return;
      }
      check_size(is_mask ? "mask" : "image", image->width, image->height);
      if (!is_mask) return;
      const std::vector<uint8_t> mask = EgoMaskFromImage(*image);
      if (!mask.empty() &&
          std::all_of(mask.begin(), mask.end(), [](uint8_t m) { return m != 0; })) {
        add("every pixel is marked as the ego body (pixels >= 128 of 255 are masked out; "
            "the rest of the image should be 0)");
      }
      return;
    }
    case FileCheck::Kind::kDepth: {
      absl::StatusOr<ImageF> depth = ReadDepth(check->path);
      if (!depth.ok()) {
        add(std::string(depth.status().message()));
        return;
      }
      check_size("depth map", depth->width, depth->height);
      return;
    }
    case FileCheck::Kind::kLidar: {
      absl::StatusOr<std::string> bytes = ReadFileToString(check->path);
      if (!bytes.ok()) {
        add(std::string(bytes.status().message()));
        return;
      }
      const int64_t size = static_cast<int64_t>(bytes->size());
      if (size % kLidarRecordBytes != 0) {
        add(absl::StrCat("file size ", size, " bytes is not a multiple of ", kLidarRecordBytes,
                         " (float32 x, y, z, intensity records)"));
        return;
      }
      int64_t bad = 0, first_bad = -1;
      for (int64_t record = 0; record < size / kLidarRecordBytes; ++record) {
        float values[4];
        std::memcpy(values, bytes->data() + record * kLidarRecordBytes, sizeof(values));
        if (!std::isfinite(values[0]) || !std::isfinite(values[1]) || !std::isfinite(values[2]) ||
            !std::isfinite(values[3])) {
          if (bad++ == 0) first_bad = record;
        }
      }
      if (bad > 0) {
        add(absl::StrCat(bad, " point(s) have non-finite values (first: point ", first_bad, ")"));
      }
      return;
    }
  }
}

}  // namespace

std::string WorldCoordinateProblem(double value) {
  if (!std::isfinite(value)) return absl::StrCat("not a finite number (", value, ")");
  if (std::abs(value) > kMaxWorldCoordinate) {
    return absl::StrCat(value, " m is beyond the ", kMaxWorldCoordinate,
                        " m any world coordinate may have");
  }
  return "";
}

std::vector<uint8_t> EgoMaskFromImage(const ImageF& image) {
  const size_t pixels = static_cast<size_t>(image.width) * image.height;
  std::vector<uint8_t> mask(pixels, 0);
  for (size_t i = 0; i < pixels; ++i) {
    mask[i] = image.pixels[i * image.channels] >= kEgoMaskThreshold ? 1 : 0;
  }
  return mask;
}

namespace {

class ClipChecker {
 public:
  ClipChecker(const LoadedClip& loaded, const ValidateOptions& options)
      : loaded_(loaded), clip_(loaded.clip), options_(options) {}

  ClipReport Run() {
    CheckCameras();
    CheckFrames();
    CheckLidar();
    CheckInstances();
    if (options_.check_files) RunFileChecks();

    ClipReport report;
    std::stable_sort(problems_.begin(), problems_.end(), [](const Keyed& a, const Keyed& b) {
      return std::make_pair(a.section, a.item) < std::make_pair(b.section, b.item);
    });
    for (Keyed& keyed : problems_) report.problems.push_back(std::move(keyed.problem));
    report.summary = summary_;
    return report;
  }

 private:
  struct Keyed {
    Section section;
    int item;
    ClipProblem problem;
  };

  void Add(Section section, int item, std::string field, std::string message) {
    problems_.push_back({section, item, {std::move(field), std::move(message)}});
  }

  // Checks that `value` is finite; adds "not a finite number" otherwise.
  bool CheckFinite(Section section, int item, const std::string& field, double value) {
    if (std::isfinite(value)) return true;
    Add(section, item, field, absl::StrCat("not a finite number (", value, ")"));
    return false;
  }

  // Checks a 16-number row-major rigid 4x4 matrix.
  void CheckPose(Section section, int item, const std::string& field,
                 const google::protobuf::RepeatedField<double>& values) {
    if (values.empty()) {
      Add(section, item, field, "missing (16 numbers: a row-major rigid 4x4 matrix)");
      return;
    }
    if (values.size() != 16) {
      Add(section, item, field,
          absl::StrCat("expected 16 numbers (a row-major 4x4 matrix), got ", values.size()));
      return;
    }
    bool finite = true;
    for (int i = 0; i < 16; ++i) {
      finite = CheckFinite(section, item, Indexed(field.c_str(), i), values[i]) && finite;
    }
    if (!finite) return;
    for (int i : {3, 7, 11}) {
      if (const std::string problem = WorldCoordinateProblem(values[i]); !problem.empty()) {
        Add(section, item, Indexed(field.c_str(), i), problem);
        return;
      }
    }
    double determinant = 0;
    const double error = RigidityError(values.data(), &determinant);
    if (error > kRigidityTolerance) {
      Add(section, item, field,
          absl::StrCat("not a rigid transform (det = ", determinant, ", deviation ", error, " > ",
                       kRigidityTolerance, ")"));
    }
  }

  // Checks a fixed-length vector of finite numbers; false if it is unusable.
  bool CheckVector(Section section, int item, const std::string& field,
                   const google::protobuf::RepeatedField<double>& values, int expected,
                   const char* meaning) {
    if (values.empty()) {
      Add(section, item, field, absl::StrCat("missing (", expected, " numbers: ", meaning, ")"));
      return false;
    }
    if (values.size() != expected) {
      Add(section, item, field,
          absl::StrCat("expected ", expected, " numbers (", meaning, "), got ", values.size()));
      return false;
    }
    bool finite = true;
    for (int i = 0; i < expected; ++i) {
      finite = CheckFinite(section, item, Indexed(field.c_str(), i), values[i]) && finite;
    }
    return finite;
  }

  // Resolves a manifest path, adding a problem when it is missing or not
  // allowed; queues a file check of `kind` when it resolves.
  void CheckPath(Section section, int item, const std::string& field, const std::string& value,
                 FileCheck::Kind kind, const Camera* camera) {
    absl::StatusOr<std::string> path =
        ResolveClipPath(loaded_, value, options_.allow_outside_paths);
    if (!path.ok()) {
      Add(section, item, field, std::string(path.status().message()));
      return;
    }
    FileCheck check;
    check.kind = kind;
    check.section = section;
    check.item = item;
    check.field = field;
    check.path = *path;
    check.camera = camera;
    file_checks_.push_back(std::move(check));
  }

  void CheckCameras() {
    summary_.cameras = clip_.cameras_size();
    if (clip_.cameras().empty()) {
      Add(Section::kCameras, -1, "cameras", "missing (a clip needs at least one camera)");
    }
    for (int i = 0; i < clip_.cameras_size(); ++i) {
      const Camera& camera = clip_.cameras(i);
      const std::string at = Indexed("cameras", i);
      auto add = [&](const std::string& field, std::string message) {
        Add(Section::kCameras, i, absl::StrCat(at, field), std::move(message));
      };
      if (camera.id().empty()) {
        add(".id", "missing (frames refer to cameras by id)");
      } else if (auto [it, inserted] = cameras_.emplace(camera.id(), i); !inserted) {
        add(".id", absl::StrCat("duplicate camera id '", camera.id(), "' (also cameras[",
                                it->second, "])"));
      }
      if (camera.width() <= 0) {
        add(".width", camera.width() == 0 ? "missing (image width in pixels, > 0)"
                                          : absl::StrCat("must be positive, got ", camera.width()));
      }
      if (camera.height() <= 0) {
        add(".height", camera.height() == 0
                           ? "missing (image height in pixels, > 0)"
                           : absl::StrCat("must be positive, got ", camera.height()));
      }
      if (!camera.has_intrinsics()) {
        add(".intrinsics", "missing ({fx, fy, cx, cy} in pixels)");
      } else {
        const auto& k = camera.intrinsics();
        struct Value {
          const char* name;
          double value;
          bool is_focal_length;
        };
        const Value values[] = {{"fx", k.fx(), true},
                                {"fy", k.fy(), true},
                                {"cx", k.cx(), false},
                                {"cy", k.cy(), false}};
        // An FTHETA camera's focal length is its polynomial's: 0 is allowed.
        const bool ftheta = camera.distortion().model() == Distortion::FTHETA;
        for (const auto& [name, value, is_focal_length] : values) {
          const std::string field = absl::StrCat(at, ".intrinsics.", name);
          if (!CheckFinite(Section::kCameras, i, field, value)) continue;
          if (is_focal_length && (value < 0 || (value == 0 && !ftheta))) {
            Add(Section::kCameras, i, field,
                value == 0 ? "missing (focal length in pixels, > 0)"
                           : absl::StrCat("focal length must be positive, got ", value));
          }
        }
      }
      if (camera.has_distortion()) CheckDistortion(i, at, camera);
      if (!camera.ego_mask().empty()) {
        CheckPath(Section::kCameras, i, at + ".egoMask", camera.ego_mask(),
                  FileCheck::Kind::kEgoMask, &camera);
      }
    }
  }

  void CheckDistortion(int i, const std::string& at, const Camera& camera) {
    const Distortion& d = camera.distortion();
    const std::pair<const char*, double> values[] = {{"k1", d.k1()}, {"k2", d.k2()},
                                                     {"p1", d.p1()}, {"p2", d.p2()},
                                                     {"k3", d.k3()}, {"k4", d.k4()}};
    bool any_set = false;
    for (const auto& [name, value] : values) {
      CheckFinite(Section::kCameras, i, absl::StrCat(at, ".distortion.", name), value);
      any_set = any_set || value != 0;
    }
    const std::string model_field = absl::StrCat(at, ".distortion.model");
    const bool polynomial_set = d.ftheta_poly_size() > 0 || d.ftheta_inverse_poly_size() > 0;
    if (polynomial_set && d.model() != Distortion::FTHETA) {
      Add(Section::kCameras, i,
          absl::StrCat(at, d.ftheta_poly_size() > 0 ? ".distortion.fthetaPoly"
                                                    : ".distortion.fthetaInversePoly"),
          "only the FTHETA model uses the f-theta polynomials; set the model to FTHETA");
    }
    switch (d.model()) {
      case Distortion::MODEL_UNSPECIFIED:
      case Distortion::NONE:
        if (any_set) {
          Add(Section::kCameras, i, model_field,
              "coefficients are set but the model is NONE; set OPENCV, FISHEYE or FTHETA");
        }
        break;
      case Distortion::FTHETA: {
        if (any_set) {
          Add(Section::kCameras, i, model_field,
              "the FTHETA model takes fthetaPoly (or fthetaInversePoly), not k1..k4, p1, p2");
        }
        // Sizes and negative focal lengths are reported by the camera's checks.
        if (camera.width() <= 0 || camera.height() <= 0 || !camera.has_intrinsics() ||
            camera.intrinsics().fx() < 0 || camera.intrinsics().fy() < 0) {
          break;
        }
        const absl::StatusOr<std::vector<double>> poly = FThetaPolynomialFromProto(camera);
        if (!poly.ok()) {
          // "<field>: <problem>", the field under the camera.
          const std::string message(poly.status().message());
          const size_t colon = message.find(": ");
          Add(Section::kCameras, i, absl::StrCat(at, ".", message.substr(0, colon)),
              colon == std::string::npos ? message : message.substr(colon + 2));
        }
        break;
      }
      case Distortion::OPENCV:
        if (d.k4() != 0) {
          Add(Section::kCameras, i, absl::StrCat(at, ".distortion.k4"),
              "only the FISHEYE model uses k4 (OPENCV uses k1, k2, p1, p2, k3)");
        }
        break;
      case Distortion::FISHEYE:
        if (d.p1() != 0 || d.p2() != 0) {
          Add(Section::kCameras, i,
              absl::StrCat(at, d.p1() != 0 ? ".distortion.p1" : ".distortion.p2"),
              "the FISHEYE model has no p1, p2 (it uses k1..k4)");
        }
        break;
      default:
        Add(Section::kCameras, i, model_field,
            absl::StrCat("unknown model ", static_cast<int>(d.model())));
        break;
    }
  }

  void CheckFrames() {
    summary_.frames = clip_.frames_size();
    if (clip_.frames().empty()) {
      Add(Section::kFrames, -1, "frames", "missing (a clip needs at least one frame)");
    }
    std::map<std::pair<std::string, int64_t>, int> seen;
    for (int i = 0; i < clip_.frames_size(); ++i) {
      const Frame& frame = clip_.frames(i);
      const std::string at = Indexed("frames", i);
      auto add = [&](const std::string& field, std::string message) {
        Add(Section::kFrames, i, absl::StrCat(at, field), std::move(message));
      };

      // Summary.
      if (i == 0 || frame.timestamp_us() < summary_.first_timestamp_us) {
        summary_.first_timestamp_us = frame.timestamp_us();
      }
      if (i == 0 || frame.timestamp_us() > summary_.last_timestamp_us) {
        summary_.last_timestamp_us = frame.timestamp_us();
      }
      if (frame.role() == Frame::TARGET) {
        ++summary_.target_frames;
      } else if (frame.role() == Frame::CONTEXT || frame.role() == Frame::ROLE_UNSPECIFIED) {
        ++summary_.context_frames;
      } else {
        add(".role", absl::StrCat("unknown role ", static_cast<int>(frame.role())));
      }

      // Camera.
      const Camera* camera = nullptr;
      if (frame.camera().empty()) {
        add(".camera", "missing (the id of one of the cameras)");
      } else if (auto it = cameras_.find(frame.camera()); it == cameras_.end()) {
        add(".camera", absl::StrCat("unknown camera id '", frame.camera(), "'", KnownCameras()));
      } else {
        camera = &clip_.cameras(it->second);
      }
      if (!frame.camera().empty()) {
        const auto [it, inserted] =
            seen.emplace(std::make_pair(frame.camera(), frame.timestamp_us()), i);
        if (!inserted) {
          add(".timestampUs",
              absl::StrCat("duplicate (camera '", frame.camera(), "', timestampUs ",
                           frame.timestamp_us(), "): also frames[", it->second, "]"));
        }
      }

      // Files and pose.
      if (frame.image().empty()) {
        add(".image", "missing (path to the PNG or JPEG)");
      } else {
        CheckPath(Section::kFrames, i, at + ".image", frame.image(), FileCheck::Kind::kImage,
                  camera);
      }
      CheckPose(Section::kFrames, i, at + ".worldFromCamera", frame.world_from_camera());
      if (frame.has_rolling_shutter()) {
        const pointforward::v1::RollingShutter& shutter = frame.rolling_shutter();
        if (shutter.readout() == pointforward::v1::RollingShutter::READOUT_UNSPECIFIED) {
          add(".rollingShutter.readout",
              "missing (say which line is read first: TOP_TO_BOTTOM, BOTTOM_TO_TOP, "
              "LEFT_TO_RIGHT or RIGHT_TO_LEFT)");
        }
        if (shutter.readout_us() < 0) {
          add(".rollingShutter.readoutUs",
              absl::StrCat("must be >= 0 (first line to last), got ", shutter.readout_us()));
        }
        CheckPose(Section::kFrames, i, at + ".rollingShutter.worldFromCameraEnd",
                  shutter.world_from_camera_end());
      }
      if (!frame.depth().empty()) {
        CheckPath(Section::kFrames, i, at + ".depth", frame.depth(), FileCheck::Kind::kDepth,
                  camera);
      }
    }
    if (!clip_.frames().empty() && summary_.context_frames == 0) {
      Add(Section::kFrames, std::numeric_limits<int>::max(), "frames",
          "no CONTEXT frames (reconstruction needs at least one; ROLE_UNSPECIFIED counts as "
          "CONTEXT)");
    }
  }

  // Returns " (known: a, b, c)" for unknown-id messages.
  std::string KnownCameras() const {
    if (cameras_.empty()) return " (the clip has no cameras)";
    std::vector<std::string> ids;
    for (const auto& [id, index] : cameras_) ids.push_back(id);
    if (ids.size() > 8) ids.resize(8), ids.push_back("...");
    return absl::StrCat(" (known: ", absl::StrJoin(ids, ", "), ")");
  }

  void CheckLidar() {
    summary_.lidar_sweeps = clip_.lidar_size();
    for (int i = 0; i < clip_.lidar_size(); ++i) {
      const LidarSweep& sweep = clip_.lidar(i);
      const std::string at = Indexed("lidar", i);
      if (sweep.points().empty()) {
        Add(Section::kLidar, i, at + ".points",
            "missing (path to float32 x, y, z, intensity records)");
      } else {
        CheckPath(Section::kLidar, i, at + ".points", sweep.points(), FileCheck::Kind::kLidar,
                  nullptr);
      }
      CheckPose(Section::kLidar, i, at + ".worldFromSensor", sweep.world_from_sensor());
    }
  }

  void CheckInstances() {
    summary_.instances = clip_.instances_size();
    std::map<std::string, int> ids;
    for (int i = 0; i < clip_.instances_size(); ++i) {
      const Instance& instance = clip_.instances(i);
      const std::string at = Indexed("instances", i);
      auto add = [&](const std::string& field, std::string message) {
        Add(Section::kInstances, i, absl::StrCat(at, field), std::move(message));
      };
      if (instance.id().empty()) {
        add(".id", "missing (a name unique within the clip)");
      } else if (auto [it, inserted] = ids.emplace(instance.id(), i); !inserted) {
        add(".id", absl::StrCat("duplicate instance id '", instance.id(), "' (also instances[",
                                it->second, "])"));
      }
      if (instance.boxes().empty()) add(".boxes", "missing (an instance needs at least one box)");
      summary_.boxes += instance.boxes_size();
      std::map<int64_t, int> timestamps;
      for (int j = 0; j < instance.boxes_size(); ++j) {
        CheckBox(i, absl::StrCat(at, ".", Indexed("boxes", j)), instance.boxes(j));
        const int64_t t = instance.boxes(j).timestamp_us();
        if (auto [it, inserted] = timestamps.emplace(t, j); !inserted) {
          add(absl::StrCat(".", Indexed("boxes", j), ".timestampUs"),
              absl::StrCat("duplicate timestamp ", t, " (also boxes[", it->second, "])"));
        }
      }
    }
  }

  void CheckBox(int i, const std::string& at, const Box& box) {
    if (CheckVector(Section::kInstances, i, at + ".center", box.center(), 3, "x, y, z in metres")) {
      for (int k = 0; k < 3; ++k) {
        if (const std::string problem = WorldCoordinateProblem(box.center(k)); !problem.empty()) {
          Add(Section::kInstances, i, Indexed((at + ".center").c_str(), k), problem);
          break;
        }
      }
    }
    if (CheckVector(Section::kInstances, i, at + ".size", box.size(), 3,
                    "length, width, height in metres")) {
      for (int k = 0; k < 3; ++k) {
        if (box.size(k) <= 0) {
          Add(Section::kInstances, i, absl::StrCat(at, ".size[", k, "]"),
              absl::StrCat("box size must be positive, got ", box.size(k)));
        }
      }
    }
    if (CheckVector(Section::kInstances, i, at + ".rotation", box.rotation(), 4,
                    "quaternion w, x, y, z, box-to-world")) {
      const Quat q{box.rotation(0), box.rotation(1), box.rotation(2), box.rotation(3)};
      const double norm = QuatNorm(q);
      if (std::abs(norm - 1.0) > kQuaternionTolerance) {
        Add(Section::kInstances, i, at + ".rotation",
            absl::StrCat("not a unit quaternion (norm = ", norm, ", tolerance ",
                         kQuaternionTolerance, ")"));
      }
    }
  }

  void RunFileChecks() {
    DefaultThreadPool().ParallelFor(0, static_cast<int64_t>(file_checks_.size()), 1,
                                    [this](int64_t begin, int64_t end) {
                                      for (int64_t k = begin; k < end; ++k) {
                                        RunFileCheck(&file_checks_[k]);
                                      }
                                    });
    for (FileCheck& check : file_checks_) {
      for (ClipProblem& problem : check.problems) {
        problems_.push_back({check.section, check.item, std::move(problem)});
      }
    }
  }

  const LoadedClip& loaded_;
  const Clip& clip_;
  const ValidateOptions& options_;
  std::map<std::string, int> cameras_;  // id -> index of its first definition.
  std::vector<FileCheck> file_checks_;
  std::vector<Keyed> problems_;
  ClipSummary summary_;
};

// Returns "1 camera" / "3 cameras".
std::string Count(int64_t n, const char* singular, const char* plural) {
  return absl::StrCat(n, " ", n == 1 ? singular : plural);
}

}  // namespace

std::string ClipSummary::ToString() const {
  return absl::StrCat(Count(cameras, "camera", "cameras"), ", ", Count(frames, "frame", "frames"),
                      " (", context_frames, " CONTEXT, ", target_frames, " TARGET), timestamps ",
                      first_timestamp_us, "..", last_timestamp_us, " us, ",
                      Count(instances, "instance", "instances"), ", ",
                      Count(lidar_sweeps, "LiDAR sweep", "LiDAR sweeps"));
}

ClipReport ValidateClip(const LoadedClip& loaded, const ValidateOptions& options) {
  return ClipChecker(loaded, options).Run();
}

ClipReport ValidateClipFile(const std::string& path, const ValidateOptions& options) {
  std::vector<ClipProblem> problems;
  absl::StatusOr<LoadedClip> loaded = LoadClip(path, &problems);
  if (!loaded.ok()) {
    ClipReport report;
    report.problems = std::move(problems);
    if (report.problems.empty())
      report.problems.push_back({"", std::string(loaded.status().message())});
    return report;
  }
  return ValidateClip(*loaded, options);
}

absl::StatusOr<LoadedClip> LoadValidClip(const std::string& path, const ValidateOptions& options) {
  std::vector<ClipProblem> problems;
  absl::StatusOr<LoadedClip> loaded = LoadClip(path, &problems);
  if (!loaded.ok() &&
      (problems.empty() || loaded.status().code() != absl::StatusCode::kInvalidArgument)) {
    return loaded.status();
  }
  if (loaded.ok()) problems = ValidateClip(*loaded, options).problems;
  if (problems.empty()) return loaded;
  if (problems.size() == 1) return absl::InvalidArgumentError(ClipProblemLine(problems[0], path));
  std::string message =
      absl::StrCat(path, ": ", problems.size(), " problems (pf validate lists them):");
  for (const ClipProblem& problem : problems) {
    absl::StrAppend(&message, "\n  ", ClipProblemLine(problem, path));
  }
  return absl::InvalidArgumentError(message);
}

std::string ClipProblemLine(const ClipProblem& problem, const std::string& path) {
  std::string line = problem.ToString();
  if (problem.field.empty() && line.rfind(path, 0) != 0) line = absl::StrCat(path, ": ", line);
  return line;
}

absl::StatusOr<std::string> ResolveClipPath(const LoadedClip& loaded, const std::string& relative,
                                            bool allow_outside) {
  return ResolvePath(loaded.dir, relative,
                     allow_outside ? PathPolicy::kAllowOutside : PathPolicy::kUnderRootOnly);
}

}  // namespace pf
