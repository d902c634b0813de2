// EXR, PNG preview and manifest writers on OpenImageIO and nlohmann::json.
// No protobuf headers here (they clash with OpenEXR's).
#include "engine/render/render_outputs.h"

#include <OpenImageIO/half.h>
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstring>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "common/file_util.h"
#include "common/status_macros.h"
#include "common/version.h"
#include "engine/image/image_io.h"
#include "engine/image/oiio_write.h"
#include "engine/render/ego_layer.h"
#include "engine/render/hole_fill.h"

#ifndef PF_SOFTWARE_VERSION
#define PF_SOFTWARE_VERSION "unknown"
#endif

namespace pf {
namespace {

using Json = nlohmann::ordered_json;
using OIIO::TypeDesc;

// One EXR channel: name, file type and where its value comes from.
struct ChannelSource {
  std::string name;
  TypeDesc type;
  const float* floats = nullptr;    // Interleaved source with `stride` values per pixel...
  const uint32_t* uints = nullptr;  // ...or a uint source (stride 1).
  int stride = 1;
};

// Camera-from-world as OpenEXR's worldToCamera: camera axes x right, y up,
// z forward, stored transposed (Imath multiplies row vectors).
std::array<float, 16> ExrWorldToCamera(const Rigid& world_from_camera) {
  Rigid camera_from_world = world_from_camera.Inverse();
  // OpenCV (y down) to OpenEXR (y up): negate the camera y row.
  for (int c = 0; c < 3; ++c) camera_from_world.rotation.m[1][c] *= -1;
  camera_from_world.translation.y *= -1;
  const std::array<double, 16> b = camera_from_world.ToRowMajor();
  std::array<float, 16> m{};
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) m[4 * r + c] = static_cast<float>(b[4 * c + r]);
  }
  return m;
}

std::vector<ChannelSource> Sources(const RenderBuffers& buffers, const OutputChannels& channels,
                                   const std::vector<float>& linear_rgb,
                                   const std::vector<float>& filled) {
  std::vector<ChannelSource> sources;
  if (channels.rgb) {
    for (int c = 0; c < 3; ++c) {
      sources.push_back(
          {std::string(1, "RGB"[c]), TypeDesc::HALF, linear_rgb.data() + c, nullptr, 3});
    }
  }
  if (channels.alpha) sources.push_back({"A", TypeDesc::HALF, buffers.alpha.data(), nullptr, 1});
  if (channels.depth) sources.push_back({"Z", TypeDesc::FLOAT, buffers.depth.data(), nullptr, 1});
  if (channels.features) {
    for (int c = 0; c < buffers.channels; ++c) {
      sources.push_back({absl::StrFormat("feature.%03d", c), TypeDesc::HALF,
                         buffers.features.data() + c, nullptr, buffers.channels});
    }
  }
  if (channels.instance) {
    sources.push_back({"instance", TypeDesc::UINT, nullptr, buffers.instance.data(), 1});
  }
  if (channels.filled) {
    for (int c = 0; c < 3; ++c) {
      sources.push_back({absl::StrCat("filled.", std::string(1, "RGB"[c])), TypeDesc::HALF,
                         filled.data() + c, nullptr, 3});
    }
  }
  return sources;
}

absl::Status CheckLayer(const char* name, size_t actual, size_t expected) {
  if (actual == expected) return absl::OkStatus();
  return absl::InvalidArgumentError(absl::StrCat("render buffers: layer '", name, "' has ", actual,
                                                 " values, expected ", expected));
}

}  // namespace

absl::StatusOr<OutputChannels> ParseOutputChannels(const std::vector<std::string>& names) {
  if (names.empty()) return OutputChannels{};
  OutputChannels out{false, false, false, false, false, false};
  for (const std::string& name : names) {
    if (name == "rgb") {
      out.rgb = true;
    } else if (name == "alpha") {
      out.alpha = true;
    } else if (name == "depth") {
      out.depth = true;
    } else if (name == "features") {
      out.features = true;
    } else if (name == "instance") {
      out.instance = true;
    } else if (name == "filled") {
      out.filled = true;
    } else {
      return absl::InvalidArgumentError(absl::StrCat(
          "unknown layer '", name, "' (use rgb, alpha, depth, features, instance, filled)"));
    }
  }
  return out;
}

int64_t EstimateRenderBytes(int64_t width, int64_t height, const OutputChannels& channels,
                            int num_features) {
  // Per pixel: rgb and alpha always, the selected layers, the fill's colour
  // and pyramid, and the 8-bit preview with some slack.
  int64_t floats = 3 + 1;
  if (channels.depth) floats += 1;
  if (channels.instance) floats += 1;
  if (channels.features) floats += std::max(num_features, 0);
  if (channels.filled) floats += 3 + 4;
  const int64_t per_pixel = 4 * floats + 8;
  const int64_t pixels = std::max<int64_t>(width, 0) * std::max<int64_t>(height, 0);
  if (pixels > std::numeric_limits<int64_t>::max() / per_pixel) {
    return std::numeric_limits<int64_t>::max();
  }
  return pixels * per_pixel;
}

absl::Status CheckRenderLimits(const pointforward::v1::RenderViews& views,
                               const OutputChannels& channels, int num_features,
                               const RenderLimits& limits, const std::string& prefix) {
  for (int i = 0; i < views.cameras_size(); ++i) {
    const pointforward::v1::Camera& camera = views.cameras(i);
    const int64_t pixels = int64_t{camera.width()} * int64_t{camera.height()};
    const std::string field = absl::StrCat(prefix, "cameras[", i, "]");
    if (limits.max_pixels_per_view > 0 && pixels > limits.max_pixels_per_view) {
      return absl::InvalidArgumentError(
          absl::StrCat(field, ": ", camera.width(), "x", camera.height(), " = ", pixels,
                       " pixels per view exceed the limit of ", limits.max_pixels_per_view,
                       " (--max-pixels-per-image)"));
    }
    const int64_t bytes =
        EstimateRenderBytes(camera.width(), camera.height(), channels, num_features);
    if (limits.max_bytes_per_view > 0 && bytes > limits.max_bytes_per_view) {
      return absl::InvalidArgumentError(absl::StrCat(
          field, ": rendering a ", camera.width(), "x", camera.height(), " view takes about ",
          bytes, " bytes, over the limit of ", limits.max_bytes_per_view,
          " per view (--max-render-bytes); ask for fewer outputs or pixels"));
    }
  }
  if (limits.max_pixels_per_view <= 0) return absl::OkStatus();
  for (int i = 0; i < views.lidars_size(); ++i) {
    const pointforward::v1::LidarSpec& spec = views.lidars(i).spec();
    // Zeros take the defaults; a bad spec is RenderRequestFromProto's to name.
    const double resolution = spec.azimuth_resolution_deg() > 0
                                  ? spec.azimuth_resolution_deg()
                                  : LidarSpec{}.azimuth_resolution_deg;
    if (!(resolution >= 0.01)) continue;
    const int64_t beams = spec.beam_elevations_deg_size();
    const int64_t columns = LidarColumns(LidarSpec{.azimuth_resolution_deg = resolution});
    if (beams * columns > limits.max_pixels_per_view) {
      return absl::InvalidArgumentError(
          absl::StrCat(prefix, "lidars[", i, "]: ", beams, " beams x ", columns,
                       " columns = ", beams * columns, " rays per sweep exceed the limit of ",
                       limits.max_pixels_per_view, " (--max-pixels-per-image)"));
    }
  }
  return absl::OkStatus();
}

std::vector<std::string> ExrChannelNames(const OutputChannels& channels, int num_features) {
  std::vector<std::string> names;
  if (channels.rgb) names.insert(names.end(), {"R", "G", "B"});
  if (channels.alpha) names.push_back("A");
  if (channels.depth) names.push_back("Z");
  if (channels.features) {
    for (int c = 0; c < num_features; ++c) names.push_back(absl::StrFormat("feature.%03d", c));
  }
  if (channels.instance) names.push_back("instance");
  if (channels.filled) names.insert(names.end(), {"filled.R", "filled.G", "filled.B"});
  return names;
}

absl::Status WriteRenderExr(const std::string& path, const RenderBuffers& buffers,
                            const OutputChannels& channels, const RenderView& view,
                            const SceneLabel& scene) {
  const size_t pixels = static_cast<size_t>(buffers.width) * buffers.height;
  if (pixels == 0) return absl::InvalidArgumentError(absl::StrCat(path, ": empty image"));
  if (channels.rgb) RETURN_IF_ERROR(CheckLayer("rgb", buffers.rgb.size(), 3 * pixels));
  if (channels.alpha) RETURN_IF_ERROR(CheckLayer("alpha", buffers.alpha.size(), pixels));
  if (channels.depth) RETURN_IF_ERROR(CheckLayer("depth", buffers.depth.size(), pixels));
  if (channels.features) {
    RETURN_IF_ERROR(CheckLayer("features", buffers.features.size(), pixels * buffers.channels));
  }
  if (channels.instance) RETURN_IF_ERROR(CheckLayer("instance", buffers.instance.size(), pixels));
  std::vector<float> linear_rgb, filled;
  if (channels.rgb || channels.filled) {
    RETURN_IF_ERROR(CheckLayer("alpha", buffers.alpha.size(), pixels));
    linear_rgb = LinearRgb(buffers, scene.colour_encoding);
  }
  if (channels.filled)
    filled = FillUncovered(linear_rgb, buffers.alpha, buffers.width, buffers.height);
  const std::vector<ChannelSource> sources = Sources(buffers, channels, linear_rgb, filled);
  if (sources.empty()) {
    return absl::InvalidArgumentError(absl::StrCat(path, ": no output layer selected"));
  }

  // Spec: per-channel formats, scanline, ZIP.
  OIIO::ImageSpec spec(buffers.width, buffers.height, static_cast<int>(sources.size()),
                       TypeDesc::HALF);
  spec.channelnames.clear();
  size_t pixel_bytes = 0;
  for (const ChannelSource& source : sources) {
    spec.channelnames.push_back(source.name);
    spec.channelformats.push_back(source.type);
    pixel_bytes += source.type.size();
  }
  for (size_t c = 0; c < sources.size(); ++c) {
    if (sources[c].name == "A") spec.alpha_channel = static_cast<int>(c);
    if (sources[c].name == "Z") spec.z_channel = static_cast<int>(c);
  }
  // ZIP at deflate level 1: about 20% less CPU than the default level for
  // files about 5% larger (768x576, 32 features); readers see plain ZIP.
  spec.attribute("compression", "zip:1");
  spec.attribute("worldToCamera", OIIO::TypeMatrix44,
                 ExrWorldToCamera(view.camera.world_from_camera).data());
  const std::array<double, 16> pose = view.camera.world_from_camera.ToRowMajor();
  spec.attribute("pf:worldFromCamera", TypeDesc(TypeDesc::DOUBLE, TypeDesc::MATRIX44), pose.data());
  const CameraModel& model = view.camera.model;
  const double intrinsics[4] = {model.fx(), model.fy(), model.cx(), model.cy()};
  const char* intrinsic_names[4] = {"pf:fx", "pf:fy", "pf:cx", "pf:cy"};
  for (int i = 0; i < 4; ++i) spec.attribute(intrinsic_names[i], TypeDesc::DOUBLE, &intrinsics[i]);
  spec.attribute("pf:cameraModel", view.camera_model);
  if (!view.distortion.empty()) {
    std::vector<float> coefficients(view.distortion.begin(), view.distortion.end());
    spec.attribute("pf:distortion",
                   TypeDesc(TypeDesc::FLOAT, static_cast<int>(coefficients.size())),
                   coefficients.data());
  }
  spec.attribute("pf:camera", view.camera_id);
  spec.attribute("pf:view", view.name);
  const double timestamp = static_cast<double>(view.timestamp_us);
  spec.attribute("timestamp_us", TypeDesc::DOUBLE, &timestamp);
  spec.attribute("pf:timestampUs", absl::StrCat(view.timestamp_us));
  spec.attribute("pf:sceneId", scene.scene_id);
  spec.attribute("pf:model", scene.model);
  spec.attribute("pf:version", SoftwareVersion());
  spec.attribute("software", absl::StrCat("PointForward ", SoftwareVersion()));
  // RGB is scene-linear light with Rec. 709 / sRGB primaries and a D65 white
  // (OpenEXR's chromaticities attribute, x y of red, green, blue, white).
  spec.attribute("oiio:ColorSpace", "Linear");
  static constexpr float kRec709Chromaticities[8] = {0.64f, 0.33f, 0.30f,   0.60f,
                                                     0.15f, 0.06f, 0.3127f, 0.3290f};
  spec.attribute("chromaticities", TypeDesc(TypeDesc::FLOAT, 8), kRec709Chromaticities);

  // Pack the pixels in the file's native per-channel layout, one channel at
  // a time.
  std::vector<unsigned char> packed(pixels * pixel_bytes);
  size_t offset = 0;
  for (const ChannelSource& source : sources) {
    unsigned char* out = packed.data() + offset;
    if (source.type == TypeDesc::HALF) {
      for (size_t i = 0; i < pixels; ++i, out += pixel_bytes) {
        const half value(source.floats[i * source.stride]);
        std::memcpy(out, &value, sizeof(value));
      }
    } else if (source.type == TypeDesc::FLOAT) {
      for (size_t i = 0; i < pixels; ++i, out += pixel_bytes) {
        std::memcpy(out, &source.floats[i * source.stride], sizeof(float));
      }
    } else {
      for (size_t i = 0; i < pixels; ++i, out += pixel_bytes) {
        std::memcpy(out, &source.uints[i], sizeof(uint32_t));
      }
    }
    offset += source.type.size();
  }

  return WriteImageAtomically(path, spec, TypeDesc::UNKNOWN, packed.data());
}

std::vector<float> LinearRgb(const RenderBuffers& buffers, ColourEncoding encoding) {
  if (encoding == ColourEncoding::kLinear) return buffers.rgb;
  std::vector<float> linear(buffers.rgb.size());
  for (size_t i = 0; i < buffers.alpha.size(); ++i) {
    const float alpha = buffers.alpha[i];
    for (int c = 0; c < 3; ++c) {
      const float premultiplied = buffers.rgb[3 * i + c];
      linear[3 * i + c] = alpha > 0.f ? alpha * SrgbToLinear(premultiplied / alpha) : 0.f;
    }
  }
  return linear;
}

ImageF DisplayRgb(const RenderBuffers& buffers, ColourEncoding encoding) {
  ImageF image(buffers.width, buffers.height, 3);
  for (size_t i = 0; i < image.pixels.size(); ++i) {
    const float v = std::clamp(buffers.rgb[i], 0.f, 1.f);
    image.pixels[i] = encoding == ColourEncoding::kLinear ? LinearToSrgb(v) : v;
  }
  return image;
}

absl::Status WritePreviewPng(const std::string& path, const RenderBuffers& buffers,
                             ColourEncoding encoding) {
  const size_t pixels = static_cast<size_t>(buffers.width) * buffers.height;
  RETURN_IF_ERROR(CheckLayer("rgb", buffers.rgb.size(), 3 * pixels));
  return WritePng(path, DisplayRgb(buffers, encoding));
}

namespace {

Json ManifestViews(const std::vector<ManifestEntry>& entries) {
  Json views = Json::array();
  for (const ManifestEntry& entry : entries) {
    Json item;
    item["name"] = entry.view != nullptr ? entry.view->name : "";
    item["exr"] = entry.exr;
    item["png"] = entry.png;
    if (entry.view != nullptr) {
      const RenderView& view = *entry.view;
      const CameraModel& model = view.camera.model;
      item["camera"] = view.camera_id;
      item["cameraModel"] = view.camera_model;
      item["timestampUs"] = view.timestamp_us;
      const std::array<double, 16> pose = view.camera.world_from_camera.ToRowMajor();
      item["worldFromCamera"] = Json(std::vector<double>(pose.begin(), pose.end()));
      item["intrinsics"] = {
          {"fx", model.fx()}, {"fy", model.fy()}, {"cx", model.cx()}, {"cy", model.cy()}};
      if (!view.distortion.empty()) item["distortion"] = Json(view.distortion);
      if (view.camera.rolling_shutter.has_value()) {
        const RollingShutter& shutter = *view.camera.rolling_shutter;
        static constexpr const char* kReadouts[] = {"TOP_TO_BOTTOM", "BOTTOM_TO_TOP",
                                                    "LEFT_TO_RIGHT", "RIGHT_TO_LEFT"};
        const std::array<double, 16> end = shutter.world_from_camera_end.ToRowMajor();
        item["rollingShutter"] = {
            {"readout", kReadouts[static_cast<int>(shutter.readout)]},
            {"readoutUs", shutter.readout_us},
            {"worldFromCameraEnd", std::vector<double>(end.begin(), end.end())}};
      }
    }
    item["width"] = entry.width;
    item["height"] = entry.height;
    item["channels"] = Json(entry.channels);
    item["renderMs"] = entry.render_ms;
    views.push_back(std::move(item));
  }
  return views;
}

Json ManifestLidars(const std::vector<LidarManifestEntry>& lidars) {
  Json array = Json::array();
  for (const LidarManifestEntry& l : lidars) {
    array.push_back({{"name", l.name},
                     {"rangeExr", l.range_exr},
                     {"points", l.points},
                     {"timestampUs", l.timestamp_us},
                     {"beams", l.beams},
                     {"columns", l.columns},
                     {"returns", l.returns},
                     {"worldFromSensor", l.world_from_sensor},
                     {"renderMs", l.render_ms}});
  }
  return array;
}

}  // namespace

std::string ManifestViewsJson(const std::vector<ManifestEntry>& entries) {
  return ManifestViews(entries).dump();
}

std::string ManifestLidarsJson(const std::vector<LidarManifestEntry>& lidars) {
  return ManifestLidars(lidars).dump();
}

std::string ManifestJson(const SceneLabel& scene, const std::vector<ManifestEntry>& entries,
                         const std::vector<LidarManifestEntry>& lidars) {
  Json root;
  root["scene"] = {{"id", scene.scene_id}, {"model", scene.model}};
  root["software"] = absl::StrCat("PointForward ", SoftwareVersion());
  root["views"] = ManifestViews(entries);
  if (!lidars.empty()) root["lidars"] = ManifestLidars(lidars);
  return root.dump(2) + "\n";
}

absl::StatusOr<LidarManifestEntry> RenderLidarToFiles(const GaussianScene& scene,
                                                      const LidarRenderView& lidar,
                                                      const std::vector<ActorEdit>& edits,
                                                      const std::string& out_dir) {
  ASSIGN_OR_RETURN(const RenderedSweep sweep,
                   RenderLidarSweep(scene, lidar.spec, lidar.pose, edits));
  LidarManifestEntry entry;
  entry.name = lidar.name;
  entry.range_exr = lidar.name + kLidarFileSuffixes[0];
  entry.points = lidar.name + kLidarFileSuffixes[1];
  RETURN_IF_ERROR(WriteRangeImageExr(absl::StrCat(out_dir, "/", entry.range_exr), sweep));
  RETURN_IF_ERROR(WriteSweepPoints(absl::StrCat(out_dir, "/", entry.points), sweep));
  entry.timestamp_us = lidar.pose.start_us;
  entry.beams = static_cast<int>(lidar.spec.beam_elevations_deg.size());
  entry.columns = LidarColumns(lidar.spec);
  entry.returns = sweep.hits;
  const std::array<double, 16> pose = lidar.pose.world_from_sensor_start.ToRowMajor();
  entry.world_from_sensor.assign(pose.begin(), pose.end());
  entry.render_ms = sweep.render_seconds * 1e3;
  return entry;
}

absl::StatusOr<ManifestEntry> RenderViewToFiles(
    const DeviceRenderer& renderer, const RenderView& view, const std::vector<ActorEdit>& edits,
    const OutputChannels& channels, const SceneLabel& label, const std::string& out_dir) {
  RenderOptions options;
  options.features = channels.features;
  options.depth = channels.depth;
  options.instance = channels.instance;
  const auto start = std::chrono::steady_clock::now();
  ASSIGN_OR_RETURN(RenderBuffers buffers,
                   renderer.Render(view.camera, view.timestamp_us, edits, options));
  if (const EgoLayer* ego = FindEgoLayer(renderer.scene(), view.camera_id)) {
    ApplyEgoLayer(*ego, view.timestamp_us, &buffers);
  }
  ManifestEntry entry;
  entry.render_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  entry.exr = view.name + kViewFileSuffixes[0];
  entry.png = view.name + kViewFileSuffixes[1];
  entry.view = &view;
  entry.channels = ExrChannelNames(channels, renderer.scene().num_channels);
  entry.width = buffers.width;
  entry.height = buffers.height;
  RETURN_IF_ERROR(
      WriteRenderExr(absl::StrCat(out_dir, "/", entry.exr), buffers, channels, view, label));
  RETURN_IF_ERROR(
      WritePreviewPng(absl::StrCat(out_dir, "/", entry.png), buffers, label.colour_encoding));
  return entry;
}

absl::Status WriteManifest(const std::string& path, const SceneLabel& scene,
                           const std::vector<ManifestEntry>& entries,
                           const std::vector<LidarManifestEntry>& lidars) {
  return WriteFileAtomic(path, ManifestJson(scene, entries, lidars));
}

}  // namespace pf
