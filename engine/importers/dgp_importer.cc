// DGP scene -> clip: samples and datums, calibration, images, LiDAR, boxes.
#include "engine/importers/dgp_importer.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/time/time.h"
#include "common/bounded_json.h"
#include "common/file_util.h"
#include "common/geometry.h"
#include "common/status_macros.h"
#include "engine/importers/jpeg_header.h"
#include "engine/importers/json_fields.h"
#include "engine/importers/npy.h"
#include "engine/importers/zip_reader.h"
#include "pointforward/v1/clip.pb.h"

namespace pf {
namespace {

namespace fs = std::filesystem;
namespace v1 = pointforward::v1;

// DGP's annotation type ids (dgp/proto/annotations.proto).
constexpr char kBoundingBox3dKey[] = "1";
// Reads {"rotation": {qw, qx, qy, qz}, "translation": {x, y, z}}.
absl::StatusOr<Rigid> PoseFromJson(const Json& pose, const std::string& where) {
  return JsonPose(pose, {"rotation", "qw", "qx", "qy", "qz", "translation"}, where);
}

// Intrinsics of one sensor of a calibration file.
struct DgpIntrinsics {
  double fx = 0, fy = 0, cx = 0, cy = 0;
  bool operator==(const DgpIntrinsics&) const = default;
};

class DgpImport {
 public:
  DgpImport(std::string scene_json, const ImportOptions& options)
      : scene_json_(std::move(scene_json)),
        scene_dir_(fs::path(scene_json_).parent_path().string()),
        options_(options) {}

  absl::StatusOr<ImportResult> Run();

 private:
  // Path of a file the scene references; NOT_FOUND naming `where` if missing.
  absl::StatusOr<std::string> Referenced(const std::string& relative, const std::string& where);
  absl::Status LoadOntology(const Json& scene);
  absl::StatusOr<const Json*> Calibration(const std::string& key);
  absl::StatusOr<DgpIntrinsics> IntrinsicsOf(const Json& calibration, const std::string& sensor,
                                             const std::string& where);
  absl::Status AddImage(const Json& image, const std::string& camera, int64_t timestamp,
                        const Json& calibration, const std::string& where);
  absl::Status AddPointCloud(const Json& cloud, const std::string& sensor, int64_t timestamp,
                             const std::string& where);
  absl::Status AddBoxes(const std::string& relative, const Rigid& world_from_sensor,
                        int64_t timestamp, const std::string& where);

  std::string scene_json_;
  std::string scene_dir_;
  const ImportOptions& options_;
  std::map<int64_t, std::string> class_names_;
  std::map<std::string, Json> calibrations_;
  std::map<std::string, DgpIntrinsics> camera_intrinsics_;
  std::map<std::string, v1::Instance> instances_;
  std::set<int64_t> box_timestamps_;
  v1::Clip clip_;
};

absl::StatusOr<std::string> DgpImport::Referenced(const std::string& relative,
                                                  const std::string& where) {
  absl::StatusOr<std::string> path = ResolvePath(scene_dir_, relative, PathPolicy::kAllowOutside);
  if (!path.ok()) {
    return absl::InvalidArgumentError(
        absl::StrCat(where, ": ", std::string(path.status().message())));
  }
  if (!fs::is_regular_file(*path)) {
    return absl::NotFoundError(
        absl::StrCat(where, ": references ", relative, ", which is missing from ", scene_dir_));
  }
  return *path;
}

absl::Status DgpImport::LoadOntology(const Json& scene) {
  const auto it = scene.find("ontologies");
  if (it == scene.end() || !it->is_object()) return absl::OkStatus();
  const auto key = it->find(kBoundingBox3dKey);
  if (key == it->end() || !key->is_string()) return absl::OkStatus();
  ASSIGN_OR_RETURN(std::string path,
                   Referenced(absl::StrCat("ontology/", key->get<std::string>(), ".json"),
                              absl::StrCat(scene_json_, ": ontologies.1")));
  ASSIGN_OR_RETURN(Json ontology, LoadJson(path));
  ASSIGN_OR_RETURN(const Json* items, JsonArray(ontology, "items", path));
  for (size_t i = 0; i < items->size(); ++i) {
    const std::string where = absl::StrCat(path, ": items[", i, "]");
    ASSIGN_OR_RETURN(double id, JsonNumber((*items)[i], "id", where));
    ASSIGN_OR_RETURN(class_names_[static_cast<int64_t>(id)],
                     JsonString((*items)[i], "name", where));
  }
  return absl::OkStatus();
}

absl::StatusOr<const Json*> DgpImport::Calibration(const std::string& key) {
  auto it = calibrations_.find(key);
  if (it == calibrations_.end()) {
    ASSIGN_OR_RETURN(std::string path,
                     Referenced(absl::StrCat("calibration/", key, ".json"),
                                absl::StrCat(scene_json_, ": calibration_key ", key)));
    ASSIGN_OR_RETURN(Json calibration, LoadJson(path));
    it = calibrations_.emplace(key, std::move(calibration)).first;
  }
  return &it->second;
}

absl::StatusOr<DgpIntrinsics> DgpImport::IntrinsicsOf(const Json& calibration,
                                                      const std::string& sensor,
                                                      const std::string& where) {
  ASSIGN_OR_RETURN(const Json* names, JsonArray(calibration, "names", where));
  ASSIGN_OR_RETURN(const Json* intrinsics, JsonArray(calibration, "intrinsics", where));
  for (size_t i = 0; i < names->size(); ++i) {
    if (!(*names)[i].is_string() || (*names)[i].get<std::string>() != sensor) continue;
    if (i >= intrinsics->size()) {
      return absl::InvalidArgumentError(
          absl::StrCat(where, ".intrinsics: has no entry ", i, " for sensor ", sensor));
    }
    const Json& k = (*intrinsics)[i];
    const std::string kw = absl::StrCat(where, ".intrinsics[", i, "]");
    DgpIntrinsics out;
    ASSIGN_OR_RETURN(out.fx, JsonNumber(k, "fx", kw));
    ASSIGN_OR_RETURN(out.fy, JsonNumber(k, "fy", kw));
    ASSIGN_OR_RETURN(out.cx, JsonNumber(k, "cx", kw));
    ASSIGN_OR_RETURN(out.cy, JsonNumber(k, "cy", kw));
    if (k.contains("skew")) {
      ASSIGN_OR_RETURN(double skew, JsonNumber(k, "skew", kw));
      if (skew != 0) {
        return absl::UnimplementedError(
            absl::StrCat(kw, ".skew: ", skew, " is not supported (only 0)"));
      }
    }
    if (out.fx <= 0 || out.fy <= 0) {
      return absl::InvalidArgumentError(absl::StrCat(kw, ": fx and fy must be positive"));
    }
    return out;
  }
  return absl::InvalidArgumentError(absl::StrCat(where, ".names: no sensor ", sensor));
}

absl::Status DgpImport::AddImage(const Json& image, const std::string& camera, int64_t timestamp,
                                 const Json& calibration, const std::string& where) {
  ASSIGN_OR_RETURN(DgpIntrinsics k, IntrinsicsOf(calibration, camera, where + ": calibration"));
  ASSIGN_OR_RETURN(double width, JsonNumber(image, "width", where));
  ASSIGN_OR_RETURN(double height, JsonNumber(image, "height", where));
  const auto known = camera_intrinsics_.find(camera);
  if (known == camera_intrinsics_.end()) {
    camera_intrinsics_[camera] = k;
    v1::Camera* c = clip_.add_cameras();
    c->set_id(camera);
    c->set_width(static_cast<int>(width));
    c->set_height(static_cast<int>(height));
    c->mutable_intrinsics()->set_fx(k.fx);
    c->mutable_intrinsics()->set_fy(k.fy);
    // Taken as they are: the scene's own 2D boxes agree with DGP's cx, cy in
    // our convention (pixel 0's left edge at 0) better than with +0.5; see
    // docs/IMPORTERS.md for the measurement.
    c->mutable_intrinsics()->set_cx(k.cx);
    c->mutable_intrinsics()->set_cy(k.cy);
    c->mutable_distortion()->set_model(v1::Distortion::NONE);
  } else if (!(known->second == k)) {
    return absl::UnimplementedError(
        absl::StrCat(where, ": the calibration of ", camera,
                     " changes within the scene; one calibration per camera is supported"));
  }
  ASSIGN_OR_RETURN(std::string filename, JsonString(image, "filename", where));
  ASSIGN_OR_RETURN(std::string path, Referenced(filename, where));
  ASSIGN_OR_RETURN(std::string bytes, ReadFileToString(path));
  ASSIGN_OR_RETURN(JpegSize size, ReadJpegSize(bytes, path));
  if (size.width != static_cast<int>(width) || size.height != static_cast<int>(height)) {
    return absl::InvalidArgumentError(absl::StrCat(where, ": ", filename, " is ", size.width, "x",
                                                   size.height, " but the datum says ", width, "x",
                                                   height));
  }
  ASSIGN_OR_RETURN(const Json* pose, JsonMember(image, "pose", where));
  ASSIGN_OR_RETURN(Rigid world_from_camera, PoseFromJson(*pose, where + ".pose"));
  const std::string relative = absl::StrCat("images/", camera, "_", timestamp, ".jpg");
  RETURN_IF_ERROR(WriteFileAtomic((fs::path(options_.out_dir) / relative).string(), bytes));
  v1::Frame* frame = clip_.add_frames();
  frame->set_camera(camera);
  frame->set_timestamp_us(timestamp);
  frame->set_image(relative);
  SetRowMajor(world_from_camera, frame->mutable_world_from_camera());
  return absl::OkStatus();
}

absl::Status DgpImport::AddPointCloud(const Json& cloud, const std::string& sensor,
                                      int64_t timestamp, const std::string& where) {
  ASSIGN_OR_RETURN(const Json* pose, JsonMember(cloud, "pose", where));
  ASSIGN_OR_RETURN(Rigid world_from_sensor, PoseFromJson(*pose, where + ".pose"));
  // Columns: X, Y, Z and optionally INTENSITY.
  std::vector<std::string> format;
  if (const auto it = cloud.find("point_format"); it != cloud.end() && it->is_array()) {
    for (const Json& f : *it) format.push_back(f.is_string() ? f.get<std::string>() : "?");
  }
  const bool has_intensity = format.size() >= 4 && format[3] == "INTENSITY";
  if (!format.empty() &&
      (format.size() < 3 || format[0] != "X" || format[1] != "Y" || format[2] != "Z")) {
    return absl::UnimplementedError(absl::StrCat(where, ".point_format: [",
                                                 absl::StrJoin(format, ", "),
                                                 "] is not supported (X, Y, Z[, INTENSITY])"));
  }
  ASSIGN_OR_RETURN(std::string filename, JsonString(cloud, "filename", where));
  ASSIGN_OR_RETURN(std::string path, Referenced(filename, where));
  ASSIGN_OR_RETURN(ZipReader npz, ZipReader::Open(path));
  ASSIGN_OR_RETURN(std::string npy, npz.Read("data.npy"));
  ASSIGN_OR_RETURN(NpyArray points, ParseNpy(npy, path + ":data.npy"));
  const size_t columns = format.empty() ? 4 : format.size();
  if (points.shape.size() != 2 || static_cast<size_t>(points.shape[1]) != columns) {
    return absl::InvalidArgumentError(
        absl::StrCat(path, ":data.npy: shape must be N x ", columns, " to match point_format"));
  }
  const int64_t n = points.shape[0];
  std::vector<float> out(static_cast<size_t>(n) * 4);
  for (int64_t i = 0; i < n; ++i) {
    const double* p = &points.data[i * columns];
    out[4 * i + 0] = static_cast<float>(p[0]);
    out[4 * i + 1] = static_cast<float>(p[1]);
    out[4 * i + 2] = static_cast<float>(p[2]);
    out[4 * i + 3] = has_intensity ? static_cast<float>(p[3]) : 0.0f;
  }
  RETURN_IF_ERROR(AddLidarSweep(out, options_.out_dir,
                                absl::StrCat("lidar/", sensor, "_", timestamp, ".bin"), timestamp,
                                world_from_sensor, &clip_));

  if (const auto annotations = cloud.find("annotations");
      annotations != cloud.end() && annotations->is_object() &&
      annotations->contains(kBoundingBox3dKey)) {
    const Json& boxes = annotations->at(kBoundingBox3dKey);
    if (!boxes.is_string()) {
      return absl::InvalidArgumentError(absl::StrCat(where, ".annotations.1: not a string"));
    }
    RETURN_IF_ERROR(
        AddBoxes(boxes.get<std::string>(), world_from_sensor, timestamp, where + ".annotations.1"));
  }
  return absl::OkStatus();
}

absl::Status DgpImport::AddBoxes(const std::string& relative, const Rigid& world_from_sensor,
                                 int64_t timestamp, const std::string& where) {
  if (!box_timestamps_.insert(timestamp).second) return absl::OkStatus();  // One set per time.
  ASSIGN_OR_RETURN(std::string path, Referenced(relative, where));
  ASSIGN_OR_RETURN(Json file, LoadJson(path));
  ASSIGN_OR_RETURN(const Json* annotations, JsonArray(file, "annotations", path));
  for (size_t i = 0; i < annotations->size(); ++i) {
    const Json& a = (*annotations)[i];
    const std::string aw = absl::StrCat(path, ": annotations[", i, "]");
    ASSIGN_OR_RETURN(const Json* instance_id, JsonMember(a, "instance_id", aw));
    if (!instance_id->is_number_integer()) {
      return absl::InvalidArgumentError(absl::StrCat(aw, ".instance_id: not an integer"));
    }
    ASSIGN_OR_RETURN(double class_id, JsonNumber(a, "class_id", aw));
    ASSIGN_OR_RETURN(const Json* b, JsonMember(a, "box", aw));
    const std::string bw = aw + ".box";
    Vec3 size;
    ASSIGN_OR_RETURN(size.x, JsonNumber(*b, "length", bw));
    ASSIGN_OR_RETURN(size.y, JsonNumber(*b, "width", bw));
    ASSIGN_OR_RETURN(size.z, JsonNumber(*b, "height", bw));
    if (!(size.x > 0 && size.y > 0 && size.z > 0)) {
      return absl::InvalidArgumentError(
          absl::StrCat(bw, ": length, width, height must be positive"));
    }
    ASSIGN_OR_RETURN(const Json* pose, JsonMember(*b, "pose", bw));
    ASSIGN_OR_RETURN(Rigid sensor_from_box, PoseFromJson(*pose, bw + ".pose"));
    const Rigid world_from_box = world_from_sensor * sensor_from_box;
    const std::string id = instance_id->dump();  // Exact digits, even beyond 2^53.
    v1::Instance& instance = instances_[id];
    instance.set_id(id);
    const auto name = class_names_.find(static_cast<int64_t>(class_id));
    instance.set_category(name != class_names_.end()
                              ? name->second
                              : absl::StrCat("class_", static_cast<int64_t>(class_id)));
    AddBox(timestamp, world_from_box, size, &instance);
  }
  return absl::OkStatus();
}

absl::StatusOr<ImportResult> DgpImport::Run() {
  ASSIGN_OR_RETURN(Json scene, LoadJson(scene_json_));
  RETURN_IF_ERROR(LoadOntology(scene));
  ASSIGN_OR_RETURN(const Json* data, JsonArray(scene, "data", scene_json_));
  ASSIGN_OR_RETURN(const Json* samples, JsonArray(scene, "samples", scene_json_));

  // Datums by key, and the camera names the scene has.
  std::map<std::string, const Json*> datums;
  std::set<std::string> scene_cameras;
  for (size_t i = 0; i < data->size(); ++i) {
    const std::string where = absl::StrCat(scene_json_, ": data[", i, "]");
    ASSIGN_OR_RETURN(std::string key, JsonString((*data)[i], "key", where));
    datums[key] = &(*data)[i];
    ASSIGN_OR_RETURN(const Json* datum, JsonMember((*data)[i], "datum", where));
    ASSIGN_OR_RETURN(const Json* id, JsonMember((*data)[i], "id", where));
    if (datum->contains("image")) {
      ASSIGN_OR_RETURN(std::string name, JsonString(*id, "name", where + ".id"));
      scene_cameras.insert(name);
    }
  }
  for (const std::string& wanted : options_.cameras) {
    if (!scene_cameras.count(wanted)) {
      return absl::InvalidArgumentError(absl::StrCat("--cameras ", wanted,
                                                     ": no such camera in the scene (have ",
                                                     absl::StrJoin(scene_cameras, ", "), ")"));
    }
  }
  const std::set<std::string> selected =
      options_.cameras.empty()
          ? scene_cameras
          : std::set<std::string>(options_.cameras.begin(), options_.cameras.end());

  std::optional<int64_t> t0;
  for (size_t s = 0; s < samples->size(); ++s) {
    const Json& sample = (*samples)[s];
    const std::string sw = absl::StrCat(scene_json_, ": samples[", s, "]");
    ASSIGN_OR_RETURN(const Json* sample_id, JsonMember(sample, "id", sw));
    ASSIGN_OR_RETURN(std::string sample_time, JsonString(*sample_id, "timestamp", sw + ".id"));
    ASSIGN_OR_RETURN(int64_t sample_us, ParseDgpTimestamp(sample_time, sw + ".id.timestamp"));
    if (!t0) t0 = sample_us;
    if (!InTimeWindow(options_, *t0, sample_us)) continue;
    ASSIGN_OR_RETURN(std::string calibration_key, JsonString(sample, "calibration_key", sw));
    ASSIGN_OR_RETURN(const Json* calibration, Calibration(calibration_key));
    ASSIGN_OR_RETURN(const Json* keys, JsonArray(sample, "datum_keys", sw));
    for (const Json& key : *keys) {
      const auto it = key.is_string() ? datums.find(key.get<std::string>()) : datums.end();
      if (it == datums.end()) {
        return absl::InvalidArgumentError(
            absl::StrCat(sw, ".datum_keys: ", key.dump(), " is not a key of any datum"));
      }
      const Json& entry = *it->second;  // "id" and "datum" checked above.
      const Json& id = entry.at("id");
      ASSIGN_OR_RETURN(std::string name, JsonString(id, "name", sw + " datum"));
      ASSIGN_OR_RETURN(std::string time, JsonString(id, "timestamp", sw + " datum " + name));
      const std::string where = absl::StrCat(scene_json_, ": datum ", name, " at ", time);
      ASSIGN_OR_RETURN(int64_t timestamp, ParseDgpTimestamp(time, where + ".id.timestamp"));
      const Json& datum = entry.at("datum");
      if (const auto image = datum.find("image"); image != datum.end()) {
        if (selected.count(name)) {
          RETURN_IF_ERROR(AddImage(*image, name, timestamp, *calibration, where));
        }
      } else if (const auto cloud = datum.find("point_cloud"); cloud != datum.end()) {
        RETURN_IF_ERROR(AddPointCloud(*cloud, name, timestamp, where));
      }
    }
  }
  if (clip_.frames().empty()) {
    return absl::InvalidArgumentError(
        absl::StrCat(scene_json_, ": no camera images in the selected cameras and time window"));
  }
  for (auto& [id, instance] : instances_) *clip_.add_instances() = std::move(instance);
  clip_.set_name(fs::path(scene_dir_).filename().string());
  AssignRoles(options_.roles, &clip_);
  ImportResult result;
  if (clip_.lidar().empty())
    result.warnings.push_back("the scene has no point clouds: no LiDAR imported");
  if (clip_.instances().empty())
    result.warnings.push_back("no bounding_box_3d on point clouds: no instances imported");
  ASSIGN_OR_RETURN(result.manifest_path, WriteClipManifest(clip_, options_.out_dir));
  result.clip = std::move(clip_);
  return result;
}

}  // namespace

absl::StatusOr<std::string> FindDgpSceneJson(const std::string& scene) {
  std::error_code ec;
  if (fs::is_regular_file(scene, ec)) return scene;
  if (!fs::is_directory(scene, ec)) {
    return absl::NotFoundError(absl::StrCat(scene, ": no such scene directory or file"));
  }
  std::vector<std::string> found;
  for (const auto& entry : fs::directory_iterator(scene, ec)) {
    const std::string name = entry.path().filename().string();
    if (entry.is_regular_file() && absl::StartsWith(name, "scene") &&
        absl::EndsWith(name, ".json")) {
      found.push_back(entry.path().string());
    }
  }
  if (found.empty()) {
    return absl::NotFoundError(absl::StrCat(scene, ": no scene*.json in this directory"));
  }
  if (found.size() > 1) {
    std::sort(found.begin(), found.end());
    return absl::InvalidArgumentError(absl::StrCat(
        scene, ": several scene JSON files; pass one of them: ", absl::StrJoin(found, ", ")));
  }
  return found.front();
}

absl::StatusOr<int64_t> ParseDgpTimestamp(const std::string& text, const std::string& field) {
  absl::Time time;
  std::string error;
  if (!absl::ParseTime(absl::RFC3339_full, text, &time, &error)) {
    return absl::InvalidArgumentError(
        absl::StrCat(field, ": '", text, "' is not an ISO-8601 time (", error, ")"));
  }
  return absl::ToUnixMicros(time);
}

absl::StatusOr<ImportResult> ImportDgp(const std::string& scene, const ImportOptions& options) {
  ASSIGN_OR_RETURN(std::string scene_json, FindDgpSceneJson(scene));
  DgpImport import(scene_json, options);
  return import.Run();
}

}  // namespace pf
