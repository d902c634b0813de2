// Manifest writing and the summary line.
#include "engine/importers/clip_output.h"

#include <google/protobuf/util/json_util.h>

#include <algorithm>
#include <filesystem>
#include <limits>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "common/file_util.h"
#include "common/status_macros.h"

namespace pf {

absl::StatusOr<std::string> WriteClipManifest(const pointforward::v1::Clip& clip,
                                              const std::string& out_dir) {
  google::protobuf::util::JsonPrintOptions options;
  options.add_whitespace = true;
  std::string json;
  const auto status = google::protobuf::util::MessageToJsonString(clip, &json, options);
  if (!status.ok()) {
    return absl::InternalError(
        absl::StrCat("clip manifest: JSON conversion failed: ", std::string(status.message())));
  }
  const std::string path = (std::filesystem::path(out_dir) / kManifestName).string();
  RETURN_IF_ERROR(WriteFileAtomic(path, json));
  return path;
}

std::string SummarizeClip(const pointforward::v1::Clip& clip) {
  int context = 0;
  int64_t t0 = std::numeric_limits<int64_t>::max(), t1 = std::numeric_limits<int64_t>::min();
  for (const auto& f : clip.frames()) {
    if (f.role() != pointforward::v1::Frame::TARGET) ++context;
    t0 = std::min(t0, f.timestamp_us());
    t1 = std::max(t1, f.timestamp_us());
  }
  int boxes = 0;
  for (const auto& instance : clip.instances()) boxes += instance.boxes_size();
  std::string range = clip.frames().empty() ? "none" : absl::StrCat("[", t0, ", ", t1, "] us");
  return absl::StrCat(clip.cameras_size(), " cameras, ", clip.frames_size(), " frames (", context,
                      " context, ", clip.frames_size() - context, " target), timestamps ", range,
                      ", ", clip.instances_size(), " instances (", boxes, " boxes), ",
                      clip.lidar_size(), " LiDAR sweeps");
}

void SetRowMajor(const Rigid& t, google::protobuf::RepeatedField<double>* out) {
  out->Clear();
  for (double v : t.ToRowMajor()) out->Add(v);
}

void AddBox(int64_t timestamp_us, const Rigid& world_from_box, const Vec3& size,
            pointforward::v1::Instance* instance) {
  pointforward::v1::Box* box = instance->add_boxes();
  box->set_timestamp_us(timestamp_us);
  const Vec3& c = world_from_box.translation;
  const Quat q = FromMatrix(world_from_box.rotation);
  for (double v : {c.x, c.y, c.z}) box->add_center(v);
  for (double v : {size.x, size.y, size.z}) box->add_size(v);
  for (double v : {q.w, q.x, q.y, q.z}) box->add_rotation(v);
}

absl::Status AddLidarSweep(const std::vector<float>& points, const std::string& out_dir,
                           const std::string& relative, int64_t timestamp_us,
                           const Rigid& world_from_sensor, pointforward::v1::Clip* clip) {
  RETURN_IF_ERROR(WriteFileAtomic((std::filesystem::path(out_dir) / relative).string(),
                                  std::string_view(reinterpret_cast<const char*>(points.data()),
                                                   points.size() * sizeof(float))));
  pointforward::v1::LidarSweep* sweep = clip->add_lidar();
  sweep->set_timestamp_us(timestamp_us);
  sweep->set_points(relative);
  SetRowMajor(world_from_sensor, sweep->mutable_world_from_sensor());
  return absl::OkStatus();
}

bool InTimeWindow(const ImportOptions& options, int64_t t0, int64_t t) {
  const int64_t offset = t - t0;
  if (offset < options.start_us) return false;
  return !options.duration_us.has_value() || offset < options.start_us + *options.duration_us;
}

}  // namespace pf
