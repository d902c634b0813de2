// 3DGS PLY export and import.
#include "engine/render/ply_io.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <vector>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_split.h"
#include "common/file_util.h"
#include "common/geometry.h"
#include "common/status_macros.h"
#include "engine/render/instance_pose.h"
#include "engine/render/scene_file.h"

namespace pf {
namespace {

static_assert(std::endian::native == std::endian::little,
              "PLY writer assumes a little-endian host");

constexpr char kCommentTag[] = "pointforward";

// ---------------------------------------------------------------------------
// Export.

// Returns the names of the float properties EncodePly writes, in order.
std::vector<std::string> ExportProperties(const GaussianScene& scene, bool with_features,
                                          bool with_time) {
  std::vector<std::string> names = {"x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2"};
  const int rest = scene.sh_degree > 0 ? 3 * (scene.sh_coeffs() - 1) : 0;
  for (int i = 0; i < rest; ++i) names.push_back(absl::StrCat("f_rest_", i));
  names.push_back("opacity");
  for (int i = 0; i < 3; ++i) names.push_back(absl::StrCat("scale_", i));
  for (int i = 0; i < 4; ++i) names.push_back(absl::StrCat("rot_", i));
  if (with_features) {
    for (int c = 0; c < scene.num_channels; ++c) names.push_back(absl::StrCat("pf_feature_", c));
  }
  if (with_time) {
    names.push_back("pf_time");
    names.push_back("pf_lifespan");
  }
  if (scene.has_colour_gradients()) {
    for (int g = 0; g < 6; ++g) names.push_back(absl::StrCat("pf_colour_gradient_", g));
  }
  return names;
}

// ---------------------------------------------------------------------------
// Import: header model.

enum class PlyType { kInt8, kUint8, kInt16, kUint16, kInt32, kUint32, kFloat32, kFloat64 };

bool ParseType(absl::string_view name, PlyType* type) {
  struct Entry {
    const char* name;
    PlyType type;
  };
  static constexpr Entry kTypes[] = {
      {"char", PlyType::kInt8},      {"int8", PlyType::kInt8},       {"uchar", PlyType::kUint8},
      {"uint8", PlyType::kUint8},    {"short", PlyType::kInt16},     {"int16", PlyType::kInt16},
      {"ushort", PlyType::kUint16},  {"uint16", PlyType::kUint16},   {"int", PlyType::kInt32},
      {"int32", PlyType::kInt32},    {"uint", PlyType::kUint32},     {"uint32", PlyType::kUint32},
      {"float", PlyType::kFloat32},  {"float32", PlyType::kFloat32}, {"double", PlyType::kFloat64},
      {"float64", PlyType::kFloat64}};
  for (const Entry& entry : kTypes) {
    if (name == entry.name) {
      *type = entry.type;
      return true;
    }
  }
  return false;
}

size_t TypeSize(PlyType type) {
  switch (type) {
    case PlyType::kInt8:
    case PlyType::kUint8:
      return 1;
    case PlyType::kInt16:
    case PlyType::kUint16:
      return 2;
    case PlyType::kInt32:
    case PlyType::kUint32:
    case PlyType::kFloat32:
      return 4;
    case PlyType::kFloat64:
      return 8;
  }
  return 0;
}

struct PlyProperty {
  std::string name;
  PlyType type = PlyType::kFloat32;
  bool is_list = false;
  PlyType count_type = PlyType::kUint8;  // For lists.
};

struct PlyElement {
  std::string name;
  uint64_t count = 0;
  std::vector<PlyProperty> properties;
};

enum class PlyFormat { kAscii, kBinaryLittle, kBinaryBig };

struct PlyHeader {
  PlyFormat format = PlyFormat::kBinaryLittle;
  std::vector<PlyElement> elements;
  std::vector<std::string> comments;
  size_t body_offset = 0;  // First byte after "end_header\n".
};

absl::StatusOr<PlyHeader> ParseHeader(const std::string& bytes, const std::string& source) {
  auto error = [&source](int line, auto&&... parts) {
    return absl::InvalidArgumentError(
        absl::StrCat(source, ": PLY header line ", line, ": ", parts...));
  };
  PlyHeader header;
  size_t pos = 0;
  int line_number = 0;
  bool have_format = false;
  while (true) {
    const size_t end = bytes.find('\n', pos);
    if (end == std::string::npos) {
      return absl::InvalidArgumentError(
          absl::StrCat(source, ": PLY header has no end_header line (", bytes.size(), " bytes)"));
    }
    std::string line = bytes.substr(pos, end - pos);
    pos = end + 1;
    ++line_number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line_number == 1) {
      if (line != "ply") {
        return absl::InvalidArgumentError(
            absl::StrCat(source, ": not a PLY file (first line is not 'ply')"));
      }
      continue;
    }
    std::vector<std::string> words = absl::StrSplit(line, ' ', absl::SkipWhitespace());
    if (words.empty()) continue;
    const std::string& keyword = words[0];
    if (keyword == "end_header") break;
    if (keyword == "comment" || keyword == "obj_info") {
      header.comments.push_back(line.size() > keyword.size() ? line.substr(keyword.size() + 1)
                                                             : "");
    } else if (keyword == "format") {
      if (words.size() != 3) return error(line_number, "expected 'format <type> 1.0'");
      if (words[1] == "ascii") {
        header.format = PlyFormat::kAscii;
      } else if (words[1] == "binary_little_endian") {
        header.format = PlyFormat::kBinaryLittle;
      } else if (words[1] == "binary_big_endian") {
        header.format = PlyFormat::kBinaryBig;
      } else {
        return error(line_number, "unknown format '", words[1], "'");
      }
      have_format = true;
    } else if (keyword == "element") {
      PlyElement element;
      if (words.size() != 3 || !absl::SimpleAtoi(words[2], &element.count)) {
        return error(line_number, "expected 'element <name> <count>'");
      }
      element.name = words[1];
      header.elements.push_back(std::move(element));
    } else if (keyword == "property") {
      if (header.elements.empty()) return error(line_number, "property before any element");
      PlyProperty property;
      if (words.size() == 5 && words[1] == "list") {
        property.is_list = true;
        if (!ParseType(words[2], &property.count_type) || !ParseType(words[3], &property.type)) {
          return error(line_number, "unknown type in list property '", words[4], "'");
        }
        property.name = words[4];
      } else if (words.size() == 3) {
        if (!ParseType(words[1], &property.type)) {
          return error(line_number, "unknown type '", words[1], "' of property '", words[2], "'");
        }
        property.name = words[2];
      } else {
        return error(line_number, "expected 'property <type> <name>'");
      }
      header.elements.back().properties.push_back(std::move(property));
    } else {
      return error(line_number, "unknown keyword '", keyword, "'");
    }
  }
  if (!have_format) {
    return absl::InvalidArgumentError(absl::StrCat(source, ": PLY has no format line"));
  }
  header.body_offset = pos;
  return header;
}

// Returns the `T` stored at `bytes` as a double.
template <typename T>
double As(const char* bytes) {
  T value;
  std::memcpy(&value, bytes, sizeof(T));
  return static_cast<double>(value);
}

// Reads one binary scalar of `type` at `data` as a double.
double ReadBinary(const char* data, PlyType type, bool swap) {
  char buffer[8];
  const size_t size = TypeSize(type);
  std::memcpy(buffer, data, size);
  if (swap) std::reverse(buffer, buffer + size);
  switch (type) {
    case PlyType::kInt8:
      return As<int8_t>(buffer);
    case PlyType::kUint8:
      return As<uint8_t>(buffer);
    case PlyType::kInt16:
      return As<int16_t>(buffer);
    case PlyType::kUint16:
      return As<uint16_t>(buffer);
    case PlyType::kInt32:
      return As<int32_t>(buffer);
    case PlyType::kUint32:
      return As<uint32_t>(buffer);
    case PlyType::kFloat32:
      return As<float>(buffer);
    case PlyType::kFloat64:
      return As<double>(buffer);
  }
  return 0;
}

// Walks the body of a PLY: skips elements, or decodes them row by row.
class BodyReader {
 public:
  BodyReader(const std::string& bytes, const PlyHeader& header, const std::string& source)
      : bytes_(bytes), header_(header), source_(source), pos_(header.body_offset) {}

  // Skips one element (all its items).
  absl::Status Skip(const PlyElement& element) {
    if (element.properties.empty()) return absl::OkStatus();  // Items of no bytes.
    for (uint64_t i = 0; i < element.count; ++i) {
      if (header_.format == PlyFormat::kAscii) {
        RETURN_IF_ERROR(NextLine(element, i).status());
        continue;
      }
      for (const PlyProperty& property : element.properties) {
        uint64_t items = 1;
        if (property.is_list) {
          RETURN_IF_ERROR(Need(TypeSize(property.count_type), element, i));
          const double count = ReadBinary(bytes_.data() + pos_, property.count_type, swap());
          pos_ += TypeSize(property.count_type);
          if (count < 0) return Corrupt(element, i, "negative list length");
          // Checked before the conversion, which is undefined for NaN and for
          // values beyond uint64_t (a float count type can hold 1e30).
          const uint64_t left = bytes_.size() - pos_;
          if (!(count <= static_cast<double>(left))) {
            return Corrupt(
                element, i,
                absl::StrCat("list length ", count, " exceeds the ", left, " bytes left"));
          }
          items = static_cast<uint64_t>(count);
        }
        const uint64_t size = items * TypeSize(property.type);
        RETURN_IF_ERROR(Need(size, element, i));
        pos_ += size;
      }
    }
    return absl::OkStatus();
  }

  // Checks that `element` has only scalar properties and that its declared
  // count fits in the bytes left, so that callers may allocate for it.
  absl::Status CheckRows(const PlyElement& element) const {
    size_t row_bytes = 0;
    for (const PlyProperty& property : element.properties) {
      if (property.is_list) {
        return absl::UnimplementedError(absl::StrCat(source_, ": list property '", property.name,
                                                     "' in element '", element.name,
                                                     "' is not supported"));
      }
      row_bytes += TypeSize(property.type);
    }
    const uint64_t left = bytes_.size() - pos_;
    if (header_.format == PlyFormat::kAscii) {
      // At least one digit and one separator per value.
      const uint64_t min_row = 2 * element.properties.size();
      if (min_row > 0 && element.count > left / min_row) {
        return absl::InvalidArgumentError(
            absl::StrCat(source_, ": truncated: element '", element.name, "' declares ",
                         element.count, " items but only ", left, " bytes follow the header"));
      }
      return absl::OkStatus();
    }
    if (row_bytes > 0 && element.count > left / row_bytes) {
      // count * row_bytes may overflow; name it only when it does not.
      const std::string needed = element.count < (uint64_t{1} << 40)
                                     ? absl::StrCat(element.count * row_bytes)
                                     : "more than 2^40";
      return absl::InvalidArgumentError(absl::StrCat(
          source_, ": truncated: element '", element.name, "' declares ", element.count,
          " items of ", row_bytes, " bytes (", needed, " bytes) but only ", left,
          " bytes follow the header; the file has ", bytes_.size(), " bytes"));
    }
    return absl::OkStatus();
  }

  // Decodes the next item of `element` (scalar properties only; see
  // CheckRows) into `row` [properties].
  absl::Status ReadRow(const PlyElement& element, uint64_t item, double* row) {
    const size_t num = element.properties.size();
    if (header_.format == PlyFormat::kAscii) {
      ASSIGN_OR_RETURN(std::string line, NextLine(element, item));
      std::vector<absl::string_view> words = absl::StrSplit(line, ' ', absl::SkipWhitespace());
      if (words.size() != num) {
        return Corrupt(element, item,
                       absl::StrCat("has ", words.size(), " values, expected ", num));
      }
      for (size_t p = 0; p < num; ++p) {
        if (!absl::SimpleAtod(words[p], &row[p])) {
          return Corrupt(
              element, item,
              absl::StrCat("property '", element.properties[p].name, "' is not a number"));
        }
      }
      return absl::OkStatus();
    }
    for (size_t p = 0; p < num; ++p) {
      const PlyType type = element.properties[p].type;
      RETURN_IF_ERROR(Need(TypeSize(type), element, item));
      row[p] = ReadBinary(bytes_.data() + pos_, type, swap());
      pos_ += TypeSize(type);
    }
    return absl::OkStatus();
  }

 private:
  bool swap() const { return header_.format == PlyFormat::kBinaryBig; }

  absl::Status Need(uint64_t size, const PlyElement& element, uint64_t item) const {
    if (bytes_.size() - pos_ >= size) return absl::OkStatus();
    return absl::InvalidArgumentError(absl::StrCat(
        source_, ": truncated: element '", element.name, "' item ", item, " needs ", size,
        " bytes at offset ", pos_, " but the file has ", bytes_.size(), " bytes"));
  }

  absl::Status Corrupt(const PlyElement& element, uint64_t item, absl::string_view what) const {
    return absl::InvalidArgumentError(
        absl::StrCat(source_, ": element '", element.name, "' item ", item, ": ", what));
  }

  absl::StatusOr<std::string> NextLine(const PlyElement& element, uint64_t item) {
    while (pos_ < bytes_.size()) {
      size_t end = bytes_.find('\n', pos_);
      if (end == std::string::npos) end = bytes_.size();
      std::string line = bytes_.substr(pos_, end - pos_);
      pos_ = std::min(end + 1, bytes_.size());
      if (!line.empty() && line.back() == '\r') line.pop_back();
      if (line.find_first_not_of(" \t") != std::string::npos) return line;
    }
    return absl::InvalidArgumentError(absl::StrCat(source_, ": truncated: element '", element.name,
                                                   "' ends at item ", item, " of ", element.count));
  }

  const std::string& bytes_;
  const PlyHeader& header_;
  const std::string& source_;
  size_t pos_;
};

// Our header comment: "pointforward time_origin_us=T sh_degree=D low_pass=S
// colour_encoding=E order_band=B lidar_intensity_channel=C" (low_pass since
// scene file version 2; files without it keep the 3DGS one; colour_encoding
// since version 4, else srgb; order_band since version 5, else 0;
// lidar_intensity_channel since version 6, else -1), then "fade_begin=B
// fade_end=E" where the scene's fade span is bounded (else unbounded) and
// "render_blur=S" where it is over 0 (else 0) and "render_blur_growth=G"
// where that is (else 0); then a comment "pointforward blur_anchor=X,Y,Z,AX,AY,AZ"
// per blur anchor. INVALID_ARGUMENT for an anchor that is not six numbers.
absl::Status ParseOurComment(const std::vector<std::string>& comments, int64_t* time_origin_us,
                             std::optional<int>* sh_degree, float* low_pass,
                             ColourEncoding* colour_encoding, float* order_band,
                             int* intensity_channel, FadeSpan* fade_span, float* render_blur,
                             float* render_blur_growth, std::vector<BlurAnchor>* blur_anchors) {
  for (const std::string& comment : comments) {
    std::vector<std::string> words = absl::StrSplit(comment, ' ', absl::SkipWhitespace());
    if (words.empty() || words[0] != kCommentTag) continue;
    for (size_t i = 1; i < words.size(); ++i) {
      std::pair<std::string, std::string> kv = absl::StrSplit(words[i], absl::MaxSplits('=', 1));
      if (kv.first == "low_pass") {
        float s = 0;
        if (absl::SimpleAtof(kv.second, &s)) *low_pass = s;
        continue;
      }
      if (kv.first == "order_band") {
        float b = 0;
        if (absl::SimpleAtof(kv.second, &b)) *order_band = b;
        continue;
      }
      if (kv.first == "fade_begin" || kv.first == "fade_end") {
        float t = 0;
        if (absl::SimpleAtof(kv.second, &t)) {
          (kv.first == "fade_begin" ? fade_span->begin : fade_span->end) = t;
        }
        continue;
      }
      if (kv.first == "render_blur") {
        float s = 0;
        if (absl::SimpleAtof(kv.second, &s)) *render_blur = s;
        continue;
      }
      if (kv.first == "render_blur_growth") {
        float g = 0;
        if (absl::SimpleAtof(kv.second, &g)) *render_blur_growth = g;
        continue;
      }
      if (kv.first == "blur_anchor") {
        const std::vector<std::string> numbers = absl::StrSplit(kv.second, ',');
        BlurAnchor anchor;
        bool ok = numbers.size() == 6;
        for (size_t k = 0; ok && k < 6; ++k) {
          ok = absl::SimpleAtof(numbers[k], k < 3 ? &anchor.centre[k] : &anchor.axis[k - 3]);
        }
        if (!ok) {
          return absl::InvalidArgumentError(absl::StrCat("comment blur_anchor=", kv.second,
                                                         " is not six numbers X,Y,Z,AX,AY,AZ"));
        }
        blur_anchors->push_back(anchor);
        continue;
      }
      if (kv.first == "colour_encoding") {
        if (kv.second == "linear") *colour_encoding = ColourEncoding::kLinear;
        continue;
      }
      int64_t value = 0;
      if (!absl::SimpleAtoi(kv.second, &value)) continue;
      if (kv.first == "time_origin_us") *time_origin_us = value;
      if (kv.first == "lidar_intensity_channel") *intensity_channel = static_cast<int>(value);
      if (kv.first == "sh_degree") *sh_degree = static_cast<int>(value);
    }
  }
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<std::string> EncodePly(const GaussianScene& scene, const PlyExportOptions& options) {
  RETURN_IF_ERROR(StatusWithContext(ValidateScene(scene), "scene"));
  const size_t n = scene.size();
  const int k = scene.sh_coeffs();
  const bool with_features = scene.sh_degree >= 0 || scene.num_channels != 3;
  const bool with_time = std::any_of(scene.lifespans.begin(), scene.lifespans.end(),
                                     [](float s) { return std::isfinite(s); });
  const std::vector<std::string> names = ExportProperties(scene, with_features, with_time);

  std::string header = absl::StrCat(
      "ply\nformat binary_little_endian 1.0\ncomment ", kCommentTag,
      " time_origin_us=", scene.time_origin_us, " sh_degree=", scene.sh_degree,
      " low_pass=", scene.low_pass, " colour_encoding=", ColourEncodingName(scene.colour_encoding),
      " order_band=", scene.order_band, " lidar_intensity_channel=", scene.lidar_intensity_channel,
      scene.fade_span.bounded()
          ? absl::StrCat(" fade_begin=", scene.fade_span.begin, " fade_end=", scene.fade_span.end)
          : std::string(),
      scene.render_blur > 0 ? absl::StrCat(" render_blur=", scene.render_blur) : std::string(),
      scene.render_blur_growth > 0
          ? absl::StrFormat(" render_blur_growth=%.9g", scene.render_blur_growth)
          : std::string(),
      "\n");
  for (const BlurAnchor& a : scene.blur_anchors) {
    absl::StrAppend(
        &header,
        absl::StrFormat("comment %s blur_anchor=%.9g,%.9g,%.9g,%.9g,%.9g,%.9g\n", kCommentTag,
                        a.centre[0], a.centre[1], a.centre[2], a.axis[0], a.axis[1], a.axis[2]));
  }
  absl::StrAppend(&header, "element vertex ", n, "\n");
  for (const std::string& name : names) absl::StrAppend(&header, "property float ", name, "\n");
  absl::StrAppend(&header, "end_header\n");

  // World-from-canonical per owner, at the export time.
  const int64_t at = options.timestamp_us.value_or(scene.time_origin_us);
  std::vector<Rigid> poses(scene.instances.size() + 1);
  std::vector<Quat> pose_rotations(poses.size());
  for (size_t i = 0; i < scene.instances.size(); ++i) {
    poses[i + 1] = InstancePoseAt(scene.instances[i].boxes, at);
    pose_rotations[i + 1] = FromMatrix(poses[i + 1].rotation);
  }

  const size_t stride = names.size();
  std::vector<float> row(stride);
  std::string out = header;
  out.reserve(header.size() + n * stride * sizeof(float));
  for (size_t i = 0; i < n; ++i) {
    size_t p = 0;
    const uint32_t owner = scene.owners[i];
    Vec3 mean{scene.means[3 * i], scene.means[3 * i + 1], scene.means[3 * i + 2]};
    const float* q = &scene.rotations[4 * i];
    Quat rotation{q[0], q[1], q[2], q[3]};
    if (owner != 0) {
      mean = poses[owner] * mean;
      rotation = pose_rotations[owner] * rotation;
    }
    for (int a = 0; a < 3; ++a) row[p++] = static_cast<float>(mean[a]);
    for (int a = 0; a < 3; ++a) row[p++] = 0.f;  // Normals: unused by 3DGS.
    if (scene.sh_degree >= 0) {
      const float* sh = &scene.sh[i * 3 * k];
      for (int c = 0; c < 3; ++c) row[p++] = sh[c * k];
      for (int c = 0; c < 3; ++c) {
        for (int j = 1; j < k; ++j) row[p++] = sh[c * k + j];
      }
    } else {
      // f_dc holds the sRGB-encoded colour, which viewers show as it is.
      const float* f = &scene.features[i * scene.num_channels];
      for (int c = 0; c < 3; ++c) {
        const float value = ConvertColour(f[std::min(c, scene.num_channels - 1)],
                                          scene.colour_encoding, ColourEncoding::kSrgb);
        row[p++] = static_cast<float>((value - 0.5) / kShC0);
      }
    }
    row[p++] = scene.opacity_logits[i];
    for (int a = 0; a < 3; ++a) row[p++] = scene.log_scales[3 * i + a];
    for (double v : {rotation.w, rotation.x, rotation.y, rotation.z})
      row[p++] = static_cast<float>(v);
    if (with_features) {
      for (int c = 0; c < scene.num_channels; ++c) {
        row[p++] = scene.features[i * scene.num_channels + c];
      }
    }
    if (with_time) {
      row[p++] = scene.times[i];
      row[p++] = scene.lifespans[i];
    }
    if (scene.has_colour_gradients()) {
      for (int g = 0; g < 6; ++g) row[p++] = scene.colour_gradients[6 * i + g];
    }
    out.append(reinterpret_cast<const char*>(row.data()), stride * sizeof(float));
  }
  return out;
}

absl::Status ExportPly(const GaussianScene& scene, const std::string& path,
                       const PlyExportOptions& options) {
  absl::StatusOr<std::string> bytes = EncodePly(scene, options);
  if (!bytes.ok()) return StatusWithContext(bytes.status(), path);
  return WriteFileAtomic(path, *bytes);
}

absl::StatusOr<GaussianScene> DecodePly(const std::string& bytes, const std::string& source) {
  ASSIGN_OR_RETURN(PlyHeader header, ParseHeader(bytes, source));
  const PlyElement* vertex = nullptr;
  BodyReader body(bytes, header, source);
  for (const PlyElement& element : header.elements) {
    if (element.name == "vertex") {
      vertex = &element;
      break;  // Elements after the vertices are not needed.
    }
    RETURN_IF_ERROR(body.Skip(element));
  }
  if (vertex == nullptr) {
    return absl::InvalidArgumentError(absl::StrCat(source, ": PLY has no 'vertex' element"));
  }
  RETURN_IF_ERROR(body.CheckRows(*vertex));

  // Property lookup by name.
  auto find = [&](const std::string& name) -> int {
    for (size_t p = 0; p < vertex->properties.size(); ++p) {
      if (vertex->properties[p].name == name) return static_cast<int>(p);
    }
    return -1;
  };
  auto require = [&](const std::string& name, int* index) -> absl::Status {
    *index = find(name);
    if (*index >= 0) return absl::OkStatus();
    return absl::InvalidArgumentError(
        absl::StrCat(source, ": vertex property '", name, "' is missing"));
  };
  int xyz[3], scale[3], rot[4], opacity;
  for (int a = 0; a < 3; ++a) RETURN_IF_ERROR(require(std::string(1, "xyz"[a]), &xyz[a]));
  for (int a = 0; a < 3; ++a) RETURN_IF_ERROR(require(absl::StrCat("scale_", a), &scale[a]));
  for (int a = 0; a < 4; ++a) RETURN_IF_ERROR(require(absl::StrCat("rot_", a), &rot[a]));
  RETURN_IF_ERROR(require("opacity", &opacity));

  // Colour: SH (f_dc, f_rest) or plain red/green/blue.
  int dc[3] = {find("f_dc_0"), find("f_dc_1"), find("f_dc_2")};
  const bool has_dc = dc[0] >= 0 && dc[1] >= 0 && dc[2] >= 0;
  int rgb[3] = {find("red"), find("green"), find("blue")};
  const bool has_rgb = rgb[0] >= 0 && rgb[1] >= 0 && rgb[2] >= 0;
  if (!has_dc && !has_rgb) {
    return absl::InvalidArgumentError(absl::StrCat(
        source, ": no colour: vertex properties f_dc_0..2 or red, green, blue are missing"));
  }
  std::vector<int> rest;
  while (true) {
    const int index = find(absl::StrCat("f_rest_", rest.size()));
    if (index < 0) break;
    rest.push_back(index);
  }
  int degree = -1;
  if (has_dc) {
    for (int d = 0; d <= 3; ++d) {
      if (static_cast<int>(rest.size()) == 3 * ((d + 1) * (d + 1) - 1)) degree = d;
    }
    if (degree < 0) {
      return absl::InvalidArgumentError(
          absl::StrCat(source, ": ", rest.size(),
                       " f_rest_* properties is no SH degree (expected 0, 9, 24 or 45)"));
    }
  }
  std::vector<int> extra_features;
  while (true) {
    const int index = find(absl::StrCat("pf_feature_", extra_features.size()));
    if (index < 0) break;
    extra_features.push_back(index);
  }
  if (extra_features.size() > 256) {
    return absl::InvalidArgumentError(absl::StrCat(source, ": ", extra_features.size(),
                                                   " pf_feature_* properties (at most 256)"));
  }
  const int time_index = find("pf_time");
  const int lifespan_index = find("pf_lifespan");
  // Our colour gradients (GaussianScene::colour_gradients), all six or none.
  int gradient_index[6];
  int gradients_found = 0;
  for (int g = 0; g < 6; ++g) {
    gradient_index[g] = find(absl::StrCat("pf_colour_gradient_", g));
    gradients_found += gradient_index[g] >= 0;
  }
  if (gradients_found != 0 && gradients_found != 6) {
    return absl::InvalidArgumentError(absl::StrCat(
        source, ": ", gradients_found, " of the 6 pf_colour_gradient_* properties (all or none)"));
  }

  GaussianScene scene;
  std::optional<int> stored_degree;
  RETURN_IF_ERROR(StatusWithContext(
      ParseOurComment(header.comments, &scene.time_origin_us, &stored_degree, &scene.low_pass,
                      &scene.colour_encoding, &scene.order_band, &scene.lidar_intensity_channel,
                      &scene.fade_span, &scene.render_blur, &scene.render_blur_growth,
                      &scene.blur_anchors),
      source));
  // Our export of a scene without SH writes degree-0 f_dc; restore "no SH".
  if (degree == 0 && stored_degree == -1) degree = -1;
  scene.sh_degree = degree;
  scene.num_channels = extra_features.empty() ? 3 : static_cast<int>(extra_features.size());
  const size_t n = vertex->count;
  scene.Resize(n);
  if (gradients_found == 6 && degree < 0) scene.colour_gradients.assign(6 * n, 0.f);
  const int k = scene.sh_coeffs();
  const size_t stride = vertex->properties.size();
  const bool rgb_is_8bit = has_rgb && TypeSize(vertex->properties[rgb[0]].type) == 1;
  std::vector<double> values(stride);
  const double* row = values.data();
  for (size_t i = 0; i < n; ++i) {
    RETURN_IF_ERROR(body.ReadRow(*vertex, i, values.data()));
    for (int a = 0; a < 3; ++a) {
      scene.means[3 * i + a] = static_cast<float>(row[xyz[a]]);
      scene.log_scales[3 * i + a] = static_cast<float>(row[scale[a]]);
    }
    for (int a = 0; a < 4; ++a) scene.rotations[4 * i + a] = static_cast<float>(row[rot[a]]);
    scene.opacity_logits[i] = static_cast<float>(row[opacity]);
    float colour[3];
    for (int c = 0; c < 3; ++c) {
      colour[c] = has_dc ? static_cast<float>(0.5 + kShC0 * row[dc[c]])
                         : static_cast<float>(row[rgb[c]] / (rgb_is_8bit ? 255.0 : 1.0));
    }
    if (k > 0) {
      float* sh = &scene.sh[i * 3 * k];
      for (int c = 0; c < 3; ++c) {
        sh[c * k] = static_cast<float>(row[dc[c]]);
        for (int j = 1; j < k; ++j)
          sh[c * k + j] = static_cast<float>(row[rest[c * (k - 1) + j - 1]]);
      }
    }
    float* features = &scene.features[i * scene.num_channels];
    if (extra_features.empty()) {
      // f_dc and red/green/blue hold sRGB-encoded colour; a linear scene of ours decodes it.
      for (int c = 0; c < 3; ++c) {
        features[c] = ConvertColour(colour[c], ColourEncoding::kSrgb, scene.colour_encoding);
      }
    } else {
      for (int c = 0; c < scene.num_channels; ++c) {
        features[c] = static_cast<float>(row[extra_features[c]]);
      }
    }
    if (time_index >= 0) scene.times[i] = static_cast<float>(row[time_index]);
    if (lifespan_index >= 0) scene.lifespans[i] = static_cast<float>(row[lifespan_index]);
    if (scene.has_colour_gradients()) {
      for (int g = 0; g < 6; ++g) {
        scene.colour_gradients[6 * i + g] = static_cast<float>(row[gradient_index[g]]);
      }
    }
  }
  RETURN_IF_ERROR(StatusWithContext(ValidateScene(scene), source));
  return scene;
}

absl::StatusOr<GaussianScene> ImportPly(const std::string& path) {
  ASSIGN_OR_RETURN(std::string bytes, ReadFileToString(path));
  return DecodePly(bytes, path);
}

}  // namespace pf
