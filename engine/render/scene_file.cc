// The binary scene file: writer, validating reader.
#include "engine/render/scene_file.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <type_traits>
#include <vector>

#include "absl/strings/str_cat.h"
#include "common/file_util.h"
#include "common/hash.h"
#include "common/status_macros.h"
#include "engine/render/ego_layer.h"
#include "engine/render/render_blur.h"

namespace pf {
namespace {

namespace fs = std::filesystem;

static_assert(std::endian::native == std::endian::little,
              "the scene file stores arrays in the host layout, which must be little-endian");

constexpr size_t kPrefixBytes = 16;    // magic, version, header size
constexpr size_t kChecksumBytes = 32;  // SHA-256 trailer
constexpr uint32_t kMaxHeaderBytes = 64u << 20;
constexpr int64_t kMaxEgoLayerPixels = int64_t{1} << 28;

constexpr int kMaxChannels = 256;

// Appends plain values to a header buffer.
class HeaderWriter {
 public:
  template <typename T>
  void Put(T value) {
    static_assert(std::is_trivially_copyable_v<T>);
    bytes_.append(reinterpret_cast<const char*>(&value), sizeof(T));
  }
  void PutString(const std::string& s) {
    Put<uint32_t>(static_cast<uint32_t>(s.size()));
    bytes_.append(s);
  }
  const std::string& bytes() const { return bytes_; }

 private:
  std::string bytes_;
};

// Reads plain values from a header buffer; every read is bounds-checked and
// names the field on failure.
class HeaderReader {
 public:
  HeaderReader(const std::string& bytes, const std::string& path) : bytes_(bytes), path_(path) {}

  template <typename T>
  absl::Status Get(const char* field, T* value) {
    if (bytes_.size() - pos_ < sizeof(T)) return Truncated(field);
    std::memcpy(value, bytes_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    return absl::OkStatus();
  }
  absl::Status GetString(const char* field, std::string* value) {
    uint32_t size = 0;
    RETURN_IF_ERROR(Get(field, &size));
    if (bytes_.size() - pos_ < size) return Truncated(field);
    value->assign(bytes_.data() + pos_, size);
    pos_ += size;
    return absl::OkStatus();
  }
  size_t remaining() const { return bytes_.size() - pos_; }

 private:
  absl::Status Truncated(const char* field) const {
    return absl::InvalidArgumentError(absl::StrCat(path_, ": scene header ends inside field '",
                                                   field, "' (header is ", bytes_.size(),
                                                   " bytes)"));
  }

  const std::string& bytes_;
  const std::string& path_;
  size_t pos_ = 0;
};

// Bytes of one box record: timestamp, centre, size, rotation.
constexpr size_t kBoxBytes = sizeof(int64_t) + 10 * sizeof(double);

// The per-Gaussian arrays in file order, with their element counts per
// Gaussian. Owners are uint32, everything else float; both are 4 bytes.
template <typename SceneT>  // GaussianScene or const GaussianScene
auto Arrays(SceneT& s) {
  struct ArrayRef {
    const char* name;
    std::conditional_t<std::is_const_v<SceneT>, const void*, void*> data;
    size_t per_gaussian;
  };
  return std::vector<ArrayRef>{{"means", s.means.data(), 3},
                               {"rotations", s.rotations.data(), 4},
                               {"log_scales", s.log_scales.data(), 3},
                               {"opacity_logits", s.opacity_logits.data(), 1},
                               {"features", s.features.data(), static_cast<size_t>(s.num_channels)},
                               {"sh", s.sh.data(), static_cast<size_t>(3 * s.sh_coeffs())},
                               {"times", s.times.data(), 1},
                               {"lifespans", s.lifespans.data(), 1},
                               {"owners", s.owners.data(), 1},
                               {"colour_gradients", s.colour_gradients.data(),
                                s.colour_gradients.empty() ? size_t{0} : size_t{6}}};
}

size_t FloatsPerGaussian(int num_channels, int sh_coeffs, bool colour_gradients) {
  return 3 + 4 + 3 + 1 + static_cast<size_t>(num_channels) + 3 * static_cast<size_t>(sh_coeffs) +
         1 + 1 + 1 + (colour_gradients ? 6 : 0);
}

absl::Status CheckArraySize(const char* name, size_t actual, size_t expected) {
  if (actual == expected) return absl::OkStatus();
  return absl::InvalidArgumentError(
      absl::StrCat(name, ": has ", actual, " values, expected ", expected));
}

absl::Status CheckFinite(const char* name, const std::vector<float>& values, size_t per_item) {
  for (size_t i = 0; i < values.size(); ++i) {
    if (!std::isfinite(values[i])) {
      return absl::InvalidArgumentError(
          absl::StrCat(name, "[", i / per_item, "]: non-finite value ", values[i]));
    }
  }
  return absl::OkStatus();
}

}  // namespace

absl::Status ValidateScene(const GaussianScene& scene) {
  if (scene.num_channels < 1 || scene.num_channels > kMaxChannels) {
    return absl::InvalidArgumentError(
        absl::StrCat("num_channels: ", scene.num_channels, " is outside [1, ", kMaxChannels, "]"));
  }
  if (scene.sh_degree < -1 || scene.sh_degree > 3) {
    return absl::InvalidArgumentError(
        absl::StrCat("sh_degree: ", scene.sh_degree, " is outside [-1, 3]"));
  }
  if (!(scene.low_pass >= 0 && scene.low_pass <= kMaxLowPass)) {
    return absl::InvalidArgumentError(
        absl::StrCat("low_pass: ", scene.low_pass, " pixels^2 is outside [0, ", kMaxLowPass, "]"));
  }
  if (!(scene.order_band >= 0 && scene.order_band <= kMaxOrderBand)) {
    return absl::InvalidArgumentError(
        absl::StrCat("order_band: ", scene.order_band, " is outside [0, ", kMaxOrderBand, "]"));
  }
  if (!(scene.fade_span.begin <= scene.fade_span.end)) {
    return absl::InvalidArgumentError(absl::StrCat("fade_span: [", scene.fade_span.begin, ", ",
                                                   scene.fade_span.end, "] is not an interval"));
  }
  if (!(scene.render_blur >= 0 && scene.render_blur <= kMaxRenderBlur)) {
    return absl::InvalidArgumentError(absl::StrCat("render_blur: ", scene.render_blur,
                                                   " pixels is outside [0, ", kMaxRenderBlur, "]"));
  }
  if (!(scene.render_blur_growth >= 0 && scene.render_blur_growth <= kMaxRenderBlurGrowth)) {
    return absl::InvalidArgumentError(absl::StrCat("render_blur_growth: ", scene.render_blur_growth,
                                                   " mrad/m is outside [0, ", kMaxRenderBlurGrowth,
                                                   "]"));
  }
  for (size_t k = 0; k < scene.blur_anchors.size(); ++k) {
    RETURN_IF_ERROR(CheckBlurAnchor(scene.blur_anchors[k], absl::StrCat("blur_anchors[", k, "]")));
  }
  if (scene.lidar_intensity_channel < -1 || scene.lidar_intensity_channel >= scene.num_channels) {
    return absl::InvalidArgumentError(
        absl::StrCat("lidar_intensity_channel: ", scene.lidar_intensity_channel,
                     " is neither -1 nor a channel of the ", scene.num_channels));
  }
  for (size_t k = 0; k < scene.ego_layers.size(); ++k) {
    const std::string where = absl::StrCat("ego_layers[", k, "]");
    RETURN_IF_ERROR(CheckEgoLayer(scene.ego_layers[k], where));
    for (size_t other = 0; other < k; ++other) {
      if (scene.ego_layers[other].camera_id == scene.ego_layers[k].camera_id) {
        return absl::InvalidArgumentError(absl::StrCat(where, ": a second layer of camera '",
                                                       scene.ego_layers[k].camera_id, "'"));
      }
    }
  }
  const size_t n = scene.size();
  RETURN_IF_ERROR(CheckArraySize("means", scene.means.size(), 3 * n));
  RETURN_IF_ERROR(CheckArraySize("rotations", scene.rotations.size(), 4 * n));
  RETURN_IF_ERROR(CheckArraySize("log_scales", scene.log_scales.size(), 3 * n));
  RETURN_IF_ERROR(CheckArraySize("features", scene.features.size(), n * scene.num_channels));
  RETURN_IF_ERROR(CheckArraySize("sh", scene.sh.size(), n * 3 * scene.sh_coeffs()));
  RETURN_IF_ERROR(CheckArraySize("times", scene.times.size(), n));
  RETURN_IF_ERROR(CheckArraySize("lifespans", scene.lifespans.size(), n));
  RETURN_IF_ERROR(CheckArraySize("owners", scene.owners.size(), n));
  if (scene.has_colour_gradients()) {
    RETURN_IF_ERROR(CheckArraySize("colour_gradients", scene.colour_gradients.size(), 6 * n));
    if (scene.sh_degree >= 0) {
      return absl::InvalidArgumentError(
          "colour_gradients: only for scenes without SH (colour from the features)");
    }
    RETURN_IF_ERROR(CheckFinite("colour_gradients", scene.colour_gradients, 6));
  }
  RETURN_IF_ERROR(CheckFinite("means", scene.means, 3));
  RETURN_IF_ERROR(CheckFinite("rotations", scene.rotations, 4));
  RETURN_IF_ERROR(CheckFinite("log_scales", scene.log_scales, 3));
  RETURN_IF_ERROR(CheckFinite("times", scene.times, 1));
  for (size_t i = 0; i < n; ++i) {
    const float* q = &scene.rotations[4 * i];
    if (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3] <= 0.f) {
      return absl::InvalidArgumentError(absl::StrCat("rotations[", i, "]: zero quaternion"));
    }
    if (scene.owners[i] > scene.instances.size()) {
      return absl::InvalidArgumentError(absl::StrCat("owners[", i, "]: instance ", scene.owners[i],
                                                     " but the scene has ", scene.instances.size(),
                                                     " instances"));
    }
    if (!(scene.lifespans[i] >= 0.f)) {
      return absl::InvalidArgumentError(
          absl::StrCat("lifespans[", i, "]: ", scene.lifespans[i], " is not >= 0"));
    }
  }
  for (size_t k = 0; k < scene.instances.size(); ++k) {
    const InstanceTrack& track = scene.instances[k];
    const std::string where = absl::StrCat("instances[", k, "] ('", track.id, "')");
    if (track.id.empty()) return absl::InvalidArgumentError(absl::StrCat(where, ": empty id"));
    if (track.boxes.empty()) return absl::InvalidArgumentError(absl::StrCat(where, ": no boxes"));
    for (size_t j = 1; j < track.boxes.size(); ++j) {
      if (track.boxes[j].timestamp_us <= track.boxes[j - 1].timestamp_us) {
        return absl::InvalidArgumentError(
            absl::StrCat(where, ".boxes[", j, "]: timestamps must strictly increase"));
      }
    }
    for (size_t other = 0; other < k; ++other) {
      if (scene.instances[other].id == track.id) {
        return absl::InvalidArgumentError(absl::StrCat(where, ": duplicate id"));
      }
    }
  }
  return absl::OkStatus();
}

absl::Status SaveScene(const GaussianScene& scene, const std::string& path,
                       const std::map<std::string, std::string>& metadata) {
  RETURN_IF_ERROR(StatusWithContext(ValidateScene(scene), absl::StrCat(path, ": scene")));

  HeaderWriter header;
  header.Put<uint64_t>(scene.size());
  header.Put<int32_t>(scene.num_channels);
  header.Put<int32_t>(scene.sh_degree);
  header.Put<int64_t>(scene.time_origin_us);
  header.Put<float>(scene.low_pass);
  header.Put<uint32_t>(scene.has_colour_gradients() ? 1 : 0);
  header.Put<uint32_t>(scene.colour_encoding == ColourEncoding::kLinear ? 1 : 0);
  header.Put<float>(scene.order_band);
  header.Put<int32_t>(scene.lidar_intensity_channel);
  header.Put<float>(scene.fade_span.begin);
  header.Put<float>(scene.fade_span.end);
  header.Put<float>(scene.render_blur);
  header.Put<float>(scene.render_blur_growth);
  header.Put<uint32_t>(static_cast<uint32_t>(scene.blur_anchors.size()));
  for (const BlurAnchor& anchor : scene.blur_anchors) {
    for (float v : anchor.centre) header.Put<float>(v);
    for (float v : anchor.axis) header.Put<float>(v);
  }
  header.Put<uint32_t>(static_cast<uint32_t>(scene.instances.size()));
  for (const InstanceTrack& track : scene.instances) {
    header.PutString(track.id);
    header.PutString(track.category);
    header.Put<uint32_t>(static_cast<uint32_t>(track.boxes.size()));
    for (const TrackBox& box : track.boxes) {
      header.Put<int64_t>(box.timestamp_us);
      for (int i = 0; i < 3; ++i) header.Put<double>(box.center[i]);
      for (int i = 0; i < 3; ++i) header.Put<double>(box.size[i]);
      for (double v : {box.rotation.w, box.rotation.x, box.rotation.y, box.rotation.z}) {
        header.Put<double>(v);
      }
    }
  }
  header.Put<uint32_t>(static_cast<uint32_t>(metadata.size()));
  for (const auto& [key, value] : metadata) {
    header.PutString(key);
    header.PutString(value);
  }
  header.Put<uint32_t>(static_cast<uint32_t>(scene.ego_layers.size()));
  for (const EgoLayer& layer : scene.ego_layers) {
    header.PutString(layer.camera_id);
    header.Put<int32_t>(layer.width);
    header.Put<int32_t>(layer.height);
    header.Put<uint64_t>(layer.body_pixels());
    header.Put<uint32_t>(static_cast<uint32_t>(layer.frames.size()));
    for (const EgoLayer::Frame& frame : layer.frames) header.Put<int64_t>(frame.timestamp_us);
  }
  if (header.bytes().size() > kMaxHeaderBytes) {
    return absl::InvalidArgumentError(absl::StrCat(
        path, ": scene header of ", header.bytes().size(), " bytes exceeds ", kMaxHeaderBytes));
  }

  const fs::path parent = fs::path(path).parent_path();
  RETURN_IF_ERROR(MakeDirs(parent.string()));
  const std::string temp = TempPathFor(path);
  Sha256 hasher;
  {
    std::ofstream out(temp, std::ios::binary | std::ios::trunc);
    if (!out) {
      return absl::PermissionDeniedError(
          absl::StrCat(path, ": cannot create ", temp, ": ", std::strerror(errno)));
    }
    auto write = [&](const void* data, size_t size) {
      hasher.Update(data, size);
      out.write(static_cast<const char*>(data), static_cast<std::streamsize>(size));
    };
    write(kSceneFileMagic, sizeof(kSceneFileMagic));
    const uint32_t version = kSceneFileVersion;
    const uint32_t header_bytes = static_cast<uint32_t>(header.bytes().size());
    write(&version, sizeof(version));
    write(&header_bytes, sizeof(header_bytes));
    write(header.bytes().data(), header.bytes().size());
    for (const auto& array : Arrays(scene)) {
      write(array.data, array.per_gaussian * scene.size() * 4);
    }
    for (const EgoLayer& layer : scene.ego_layers) {
      write(layer.mask.data(), layer.mask.size());
      const std::vector<float> colours = MeanBodyColours(layer);
      write(colours.data(), colours.size() * 4);
      for (const EgoLayer::Frame& frame : layer.frames) {
        write(frame.rgb.data(), frame.rgb.size() * 4);
      }
    }
    const std::array<uint8_t, 32> digest = hasher.Finish();
    out.write(reinterpret_cast<const char*>(digest.data()), digest.size());
    out.close();
    if (!out) {
      std::error_code ec;
      fs::remove(temp, ec);
      return absl::InternalError(absl::StrCat(path, ": write failed: ", std::strerror(errno)));
    }
  }
  return CommitTempFile(temp, path);
}

absl::StatusOr<SceneFile> ReadSceneFile(const std::string& path) {
  std::error_code ec;
  const uintmax_t file_size = fs::file_size(path, ec);
  if (ec) {
    if (!fs::exists(path, ec)) return absl::NotFoundError(absl::StrCat(path, ": file not found"));
    return absl::PermissionDeniedError(absl::StrCat(path, ": cannot stat: ", ec.message()));
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    return absl::PermissionDeniedError(absl::StrCat(path, ": cannot open: ", std::strerror(errno)));
  }
  auto invalid = [&path](auto&&... parts) {
    return absl::InvalidArgumentError(absl::StrCat(path, ": ", parts...));
  };

  // Prefix: magic, version, header size.
  if (file_size < kPrefixBytes) {
    return invalid("not a PointForward scene file (", file_size, " bytes, shorter than the ",
                   kPrefixBytes, "-byte prefix)");
  }
  char prefix[kPrefixBytes];
  in.read(prefix, kPrefixBytes);
  if (std::memcmp(prefix, kSceneFileMagic, sizeof(kSceneFileMagic)) != 0) {
    return invalid("not a PointForward scene file (wrong magic)");
  }
  uint32_t version = 0, header_bytes = 0;
  std::memcpy(&version, prefix + 8, 4);
  std::memcpy(&header_bytes, prefix + 12, 4);
  if (version < kOldestSceneFileVersion || version > kSceneFileVersion) {
    return invalid("unsupported scene file version ", version, " (this build reads versions ",
                   kOldestSceneFileVersion, " to ", kSceneFileVersion, ")");
  }
  if (header_bytes > kMaxHeaderBytes || header_bytes > file_size - kPrefixBytes) {
    return invalid("truncated or corrupt: header of ", header_bytes, " bytes but the file has ",
                   file_size, " bytes");
  }
  Sha256 hasher;
  hasher.Update(prefix, kPrefixBytes);

  // Header.
  std::string header_data(header_bytes, '\0');
  in.read(header_data.data(), header_bytes);
  if (!in) return invalid("read error in the header");
  hasher.Update(header_data);
  HeaderReader header(header_data, path);
  SceneFile result;
  result.version = version;
  GaussianScene& scene = result.scene;
  uint64_t num_gaussians = 0;
  int32_t num_channels = 0, sh_degree = 0;
  RETURN_IF_ERROR(header.Get("num_gaussians", &num_gaussians));
  RETURN_IF_ERROR(header.Get("num_channels", &num_channels));
  RETURN_IF_ERROR(header.Get("sh_degree", &sh_degree));
  RETURN_IF_ERROR(header.Get("time_origin_us", &scene.time_origin_us));
  // Version 1 has no low-pass: its scenes were fitted under the 3DGS one.
  scene.low_pass = kThreeDgsLowPass;
  if (version >= 2) RETURN_IF_ERROR(header.Get("low_pass", &scene.low_pass));
  // Version 3 added colour gradients (0: flat colours, 1: [N, 3, 2]).
  uint32_t colour_gradients = 0;
  if (version >= 3) RETURN_IF_ERROR(header.Get("colour_gradients", &colour_gradients));
  if (colour_gradients > 1) {
    return invalid("header colour_gradients ", colour_gradients, " is neither 0 nor 1");
  }
  // Version 4 added the colours' encoding (0: sRGB, as every earlier scene; 1: linear).
  uint32_t linear_colours = 0;
  if (version >= 4) RETURN_IF_ERROR(header.Get("colour_encoding", &linear_colours));
  if (linear_colours > 1) {
    return invalid("header colour_encoding ", linear_colours, " is neither 0 nor 1");
  }
  scene.colour_encoding = linear_colours == 1 ? ColourEncoding::kLinear : ColourEncoding::kSrgb;
  // Version 5 added the order band (0 before: strict depth order).
  if (version >= 5) RETURN_IF_ERROR(header.Get("order_band", &scene.order_band));
  if (!(scene.order_band >= 0 && scene.order_band <= kMaxOrderBand)) {
    return invalid("header order_band ", scene.order_band, " is outside [0, ", kMaxOrderBand, "]");
  }
  // Version 6 added the LiDAR intensity channel (-1 before: none).
  int32_t intensity_channel = -1;
  if (version >= 6) RETURN_IF_ERROR(header.Get("lidar_intensity_channel", &intensity_channel));
  if (intensity_channel < -1 || intensity_channel >= num_channels) {
    return invalid("header lidar_intensity_channel ", intensity_channel,
                   " is neither -1 nor one of the ", num_channels, " channels");
  }
  scene.lidar_intensity_channel = intensity_channel;
  // Version 8 added the fade span (unbounded before).
  if (version >= 8) {
    RETURN_IF_ERROR(header.Get("fade_begin", &scene.fade_span.begin));
    RETURN_IF_ERROR(header.Get("fade_end", &scene.fade_span.end));
    if (!(scene.fade_span.begin <= scene.fade_span.end)) {
      return invalid("header fade span [", scene.fade_span.begin, ", ", scene.fade_span.end,
                     "] is not an interval");
    }
  }
  // Version 10 added the render blur (0 before).
  if (version >= 10) {
    RETURN_IF_ERROR(header.Get("render_blur", &scene.render_blur));
    if (!(scene.render_blur >= 0 && scene.render_blur <= kMaxRenderBlur)) {
      return invalid("header render_blur ", scene.render_blur, " is outside [0, ", kMaxRenderBlur,
                     "]");
    }
  }
  // Version 11 added its growth and anchors (0 and none before).
  if (version >= 11) {
    RETURN_IF_ERROR(header.Get("render_blur_growth", &scene.render_blur_growth));
    if (!(scene.render_blur_growth >= 0 && scene.render_blur_growth <= kMaxRenderBlurGrowth)) {
      return invalid("header render_blur_growth ", scene.render_blur_growth, " is outside [0, ",
                     kMaxRenderBlurGrowth, "]");
    }
    uint32_t num_anchors = 0;
    RETURN_IF_ERROR(header.Get("num_blur_anchors", &num_anchors));
    if (num_anchors > header.remaining() / 24) {
      return invalid("header num_blur_anchors ", num_anchors, " does not fit in the header");
    }
    scene.blur_anchors.resize(num_anchors);
    for (size_t k = 0; k < num_anchors; ++k) {
      BlurAnchor& anchor = scene.blur_anchors[k];
      for (float& v : anchor.centre) RETURN_IF_ERROR(header.Get("blur_anchor.centre", &v));
      for (float& v : anchor.axis) RETURN_IF_ERROR(header.Get("blur_anchor.axis", &v));
      if (absl::Status s = CheckBlurAnchor(anchor, absl::StrCat("blur anchor ", k)); !s.ok()) {
        return invalid("header ", s.message());
      }
    }
  }
  if (num_channels < 1 || num_channels > kMaxChannels) {
    return invalid("header num_channels ", num_channels, " is outside [1, ", kMaxChannels, "]");
  }
  if (sh_degree < -1 || sh_degree > 3) {
    return invalid("header sh_degree ", sh_degree, " is outside [-1, 3]");
  }
  scene.num_channels = num_channels;
  scene.sh_degree = sh_degree;
  uint32_t num_instances = 0;
  RETURN_IF_ERROR(header.Get("num_instances", &num_instances));
  // Each instance needs at least 12 bytes; reject counts the header cannot hold.
  if (num_instances > header.remaining() / 12) {
    return invalid("header num_instances ", num_instances, " does not fit in the header");
  }
  scene.instances.resize(num_instances);
  for (InstanceTrack& track : scene.instances) {
    RETURN_IF_ERROR(header.GetString("instance.id", &track.id));
    RETURN_IF_ERROR(header.GetString("instance.category", &track.category));
    uint32_t num_boxes = 0;
    RETURN_IF_ERROR(header.Get("instance.num_boxes", &num_boxes));
    if (num_boxes > header.remaining() / kBoxBytes) {
      return invalid("header instance '", track.id, "' has ", num_boxes,
                     " boxes, more than the header holds");
    }
    track.boxes.resize(num_boxes);
    for (TrackBox& box : track.boxes) {
      RETURN_IF_ERROR(header.Get("box.timestamp_us", &box.timestamp_us));
      for (int i = 0; i < 3; ++i) RETURN_IF_ERROR(header.Get("box.center", &box.center[i]));
      for (int i = 0; i < 3; ++i) RETURN_IF_ERROR(header.Get("box.size", &box.size[i]));
      RETURN_IF_ERROR(header.Get("box.rotation", &box.rotation.w));
      RETURN_IF_ERROR(header.Get("box.rotation", &box.rotation.x));
      RETURN_IF_ERROR(header.Get("box.rotation", &box.rotation.y));
      RETURN_IF_ERROR(header.Get("box.rotation", &box.rotation.z));
    }
  }
  uint32_t num_metadata = 0;
  RETURN_IF_ERROR(header.Get("num_metadata", &num_metadata));
  if (num_metadata > header.remaining() / 8) {
    return invalid("header num_metadata ", num_metadata, " does not fit in the header");
  }
  for (uint32_t i = 0; i < num_metadata; ++i) {
    std::string key, value;
    RETURN_IF_ERROR(header.GetString("metadata.key", &key));
    RETURN_IF_ERROR(header.GetString("metadata.value", &value));
    result.metadata[key] = std::move(value);
  }
  // Version 7 added the ego layers: id, width, height, body pixels.
  std::vector<uint64_t> body_pixels;
  uint64_t ego_bytes = 0;
  if (version >= 7) {
    uint32_t num_layers = 0;
    RETURN_IF_ERROR(header.Get("num_ego_layers", &num_layers));
    if (num_layers > header.remaining() / 20) {
      return invalid("header num_ego_layers ", num_layers, " does not fit in the header");
    }
    scene.ego_layers.resize(num_layers);
    for (EgoLayer& layer : scene.ego_layers) {
      uint64_t body = 0;
      RETURN_IF_ERROR(header.GetString("ego_layer.camera_id", &layer.camera_id));
      RETURN_IF_ERROR(header.Get("ego_layer.width", &layer.width));
      RETURN_IF_ERROR(header.Get("ego_layer.height", &layer.height));
      RETURN_IF_ERROR(header.Get("ego_layer.body_pixels", &body));
      const int64_t pixels = int64_t{layer.width} * layer.height;
      if (layer.width <= 0 || layer.height <= 0 || pixels > kMaxEgoLayerPixels ||
          body > static_cast<uint64_t>(pixels)) {
        return invalid("header ego layer '", layer.camera_id, "': ", layer.width, "x", layer.height,
                       " with ", body, " body pixels");
      }
      body_pixels.push_back(body);
      ego_bytes += static_cast<uint64_t>(pixels) + 12 * body;
      // Version 9 added each layer's frames: their count and times.
      if (version >= 9) {
        uint32_t num_frames = 0;
        RETURN_IF_ERROR(header.Get("ego_layer.num_frames", &num_frames));
        if (num_frames > header.remaining() / 8) {
          return invalid("header ego layer '", layer.camera_id, "': ", num_frames,
                         " frames do not fit in the header");
        }
        layer.frames.resize(num_frames);
        for (EgoLayer::Frame& frame : layer.frames) {
          RETURN_IF_ERROR(header.Get("ego_layer.frame_timestamp_us", &frame.timestamp_us));
        }
        ego_bytes += uint64_t{num_frames} * 12 * body;
      }
    }
  }
  if (header.remaining() != 0) {
    return invalid("header has ", header.remaining(), " unexpected trailing bytes");
  }

  // Sizes: the arrays and the checksum must fill the rest of the file exactly.
  if (ego_bytes > file_size - kPrefixBytes - header_bytes) {
    return invalid("truncated: the header promises ego layers of ", ego_bytes,
                   " bytes but the file has ", file_size, " bytes");
  }
  const uint64_t available = file_size - kPrefixBytes - header_bytes - ego_bytes;
  const uint64_t bytes_per_gaussian =
      4 * FloatsPerGaussian(num_channels, scene.sh_coeffs(), colour_gradients != 0);
  if (num_gaussians > available / bytes_per_gaussian) {
    return invalid("truncated: header promises ", num_gaussians, " Gaussians (",
                   kPrefixBytes + header_bytes, " + ", num_gaussians, " x ", bytes_per_gaussian,
                   " + ", kChecksumBytes, " bytes) but the file has ", file_size, " bytes");
  }
  const uint64_t expected_size =
      kPrefixBytes + header_bytes + num_gaussians * bytes_per_gaussian + ego_bytes + kChecksumBytes;
  if (expected_size != file_size) {
    return invalid(expected_size > file_size ? "truncated" : "trailing data", ": expected ",
                   expected_size, " bytes from the header, the file has ", file_size, " bytes");
  }

  // Arrays, one read each.
  scene.Resize(num_gaussians);
  if (colour_gradients != 0) scene.colour_gradients.assign(6 * num_gaussians, 0.f);
  for (const auto& array : Arrays(scene)) {
    const size_t bytes = array.per_gaussian * num_gaussians * 4;
    in.read(static_cast<char*>(array.data), static_cast<std::streamsize>(bytes));
    if (!in) return invalid("read error in array '", array.name, "'");
    hasher.Update(array.data, bytes);
  }
  for (size_t k = 0; k < scene.ego_layers.size(); ++k) {
    EgoLayer& layer = scene.ego_layers[k];
    layer.mask.resize(static_cast<size_t>(layer.width) * layer.height);
    in.read(reinterpret_cast<char*>(layer.mask.data()),
            static_cast<std::streamsize>(layer.mask.size()));
    std::vector<float> colours(body_pixels[k] * 3);
    in.read(reinterpret_cast<char*>(colours.data()),
            static_cast<std::streamsize>(colours.size() * 4));
    if (!in) return invalid("read error in ego layer '", layer.camera_id, "'");
    hasher.Update(layer.mask.data(), layer.mask.size());
    hasher.Update(colours.data(), colours.size() * 4);
    uint64_t on = 0;
    for (uint8_t& m : layer.mask) on += m = m != 0;
    if (on != body_pixels[k]) {
      return invalid("ego layer '", layer.camera_id, "': its mask has ", on,
                     " body pixels, the header says ", body_pixels[k]);
    }
    layer.rgb.assign(layer.mask.size() * 3, 0.f);
    size_t next = 0;
    for (size_t i = 0; i < layer.mask.size(); ++i) {
      if (!layer.mask[i]) continue;
      for (int c = 0; c < 3; ++c) layer.rgb[i * 3 + c] = colours[next * 3 + c];
      ++next;
    }
    for (EgoLayer::Frame& frame : layer.frames) {
      frame.rgb.resize(body_pixels[k] * 3);
      in.read(reinterpret_cast<char*>(frame.rgb.data()),
              static_cast<std::streamsize>(frame.rgb.size() * 4));
      if (!in) return invalid("read error in ego layer '", layer.camera_id, "'");
      hasher.Update(frame.rgb.data(), frame.rgb.size() * 4);
    }
  }
  std::array<uint8_t, kChecksumBytes> stored{};
  in.read(reinterpret_cast<char*>(stored.data()), kChecksumBytes);
  if (!in) return invalid("read error in the checksum");
  const std::array<uint8_t, 32> computed = hasher.Finish();
  if (computed != stored) {
    return invalid("checksum mismatch: the file is corrupt (stored ",
                   ToHex(stored.data(), stored.size()), ", computed ",
                   ToHex(computed.data(), computed.size()), ")");
  }
  result.checksum_hex = ToHex(computed.data(), computed.size());
  RETURN_IF_ERROR(StatusWithContext(ValidateScene(scene), path));
  return result;
}

absl::StatusOr<GaussianScene> LoadScene(const std::string& path) {
  ASSIGN_OR_RETURN(SceneFile file, ReadSceneFile(path));
  return std::move(file.scene);
}

bool LooksLikeSceneFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  char magic[sizeof(kSceneFileMagic)] = {};
  in.read(magic, sizeof(magic));
  return in && std::memcmp(magic, kSceneFileMagic, sizeof(magic)) == 0;
}

}  // namespace pf
