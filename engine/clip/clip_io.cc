// Clip manifest parsing and writing.
//
// Parsing goes in two steps: ParseBoundedJson turns the text into a tree
// (bounded in size and nesting; malformed JSON reported with its line and
// column, keys given twice with their path), then ManifestReader walks
// that tree against the protobuf descriptor of pointforward.v1.Clip. The walk
// follows the proto3 JSON mapping (lowerCamelCase or original field names,
// enums by name or number, 64-bit integers as numbers or decimal strings,
// doubles as numbers or "NaN"/"Infinity"/"-Infinity", null = default), fills
// the message through reflection and records every problem with its path.
#include "engine/clip/clip_io.h"

#include <google/protobuf/descriptor.h>
#include <google/protobuf/message.h>
#include <google/protobuf/reflection.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "common/bounded_json.h"
#include "common/file_util.h"
#include "common/status_macros.h"

namespace pf {
namespace {

namespace fs = std::filesystem;
namespace gpb = google::protobuf;
using Json = nlohmann::ordered_json;

constexpr char kNaN[] = "NaN";
constexpr char kInfinity[] = "Infinity";
constexpr char kMinusInfinity[] = "-Infinity";

std::string ChildPath(const std::string& path, const std::string& key) {
  return path.empty() ? key : absl::StrCat(path, ".", key);
}

std::string IndexPath(const std::string& path, size_t index) {
  return absl::StrCat(path, "[", index, "]");
}

// Returns a short description of `value` for "expected X, got Y" messages.
std::string Describe(const Json& value) {
  if (value.is_structured()) return std::string(value.type_name());
  std::string text = value.dump();
  if (text.size() > 40) text = absl::StrCat(text.substr(0, 37), "...");
  return absl::StrCat(value.type_name(), " ", text);
}

// Returns the edit distance between `a` and `b` (for "did you mean").
size_t EditDistance(const std::string& a, const std::string& b) {
  std::vector<size_t> row(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    size_t diagonal = row[0];
    row[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      const size_t above = row[j];
      const size_t substitute = diagonal + (a[i - 1] == b[j - 1] ? 0 : 1);
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, substitute});
      diagonal = above;
    }
  }
  return row[b.size()];
}

// Parses `text` as exactly one JSON number into `number`; false if it is
// anything else.
bool ParseJsonNumber(const std::string& text, Json* number) {
  absl::StatusOr<Json> parsed = ParseBoundedJson(text, {.max_bytes = 1024, .max_depth = 0});
  if (!parsed.ok() || !parsed->is_number()) return false;
  *number = *std::move(parsed);
  return true;
}

// Returns the field of `descriptor` whose JSON name (lowerCamelCase) or
// original name is `key`; null when none is.
const gpb::FieldDescriptor* FindField(const gpb::Descriptor* descriptor, const std::string& key) {
  for (int i = 0; i < descriptor->field_count(); ++i) {
    const gpb::FieldDescriptor* field = descriptor->field(i);
    if (field->json_name() == key || field->name() == key) return field;
  }
  return nullptr;
}

// Walks a JSON tree against a message descriptor, filling the message and
// collecting problems.
class ManifestReader {
 public:
  explicit ManifestReader(std::vector<ClipProblem>* problems) : problems_(problems) {}

  // Reads JSON object `value` into `message`; `path` names it in problems.
  void ReadMessage(const Json& value, const std::string& path, gpb::Message* message) {
    if (value.is_null()) return;
    if (!value.is_object()) {
      Add(path, absl::StrCat("expected an object, got ", Describe(value)));
      return;
    }
    const gpb::Descriptor* descriptor = message->GetDescriptor();
    std::set<int> seen;
    for (const auto& [key, child] : value.items()) {
      const std::string child_path = ChildPath(path, key);
      const gpb::FieldDescriptor* field = FindField(descriptor, key);
      if (field == nullptr) {
        Add(child_path, absl::StrCat("unknown field", Suggestion(key, descriptor)));
        continue;
      }
      if (!seen.insert(field->number()).second) {
        Add(child_path, absl::StrCat("field '", field->json_name(), "' given twice"));
        continue;
      }
      if (field->is_repeated()) {
        ReadRepeated(child, child_path, field, message);
      } else {
        ReadSingular(child, child_path, field, message);
      }
    }
  }

 private:
  void Add(const std::string& path, std::string message) {
    problems_->push_back({path, std::move(message)});
  }

  // Returns " (did you mean 'x'?)" for the closest field name, or "".
  static std::string Suggestion(const std::string& key, const gpb::Descriptor* descriptor) {
    std::string best;
    size_t best_distance = std::numeric_limits<size_t>::max();
    for (int i = 0; i < descriptor->field_count(); ++i) {
      const std::string& name = descriptor->field(i)->json_name();
      const size_t distance = EditDistance(key, name);
      if (distance < best_distance) {
        best_distance = distance;
        best = name;
      }
    }
    if (best.empty() || best_distance > std::max<size_t>(2, key.size() / 3)) return "";
    return absl::StrCat(" (did you mean '", best, "'?)");
  }

  void ReadRepeated(const Json& value, const std::string& path, const gpb::FieldDescriptor* field,
                    gpb::Message* message) {
    if (value.is_null()) return;
    if (!value.is_array()) {
      Add(path, absl::StrCat("expected an array, got ", Describe(value)));
      return;
    }
    const gpb::Reflection* reflection = message->GetReflection();
    for (size_t i = 0; i < value.size(); ++i) {
      const Json& item = value[i];
      const std::string item_path = IndexPath(path, i);
      if (field->cpp_type() == gpb::FieldDescriptor::CPPTYPE_MESSAGE) {
        if (!item.is_object()) {
          Add(item_path, absl::StrCat("expected an object, got ", Describe(item)));
          continue;
        }
        ReadMessage(item, item_path, reflection->AddMessage(message, field));
        continue;
      }
      if (item.is_null()) {
        Add(item_path, "null is not allowed inside an array");
        continue;
      }
      ReadScalar(item, item_path, field, message, /*add=*/true);
    }
  }

  void ReadSingular(const Json& value, const std::string& path, const gpb::FieldDescriptor* field,
                    gpb::Message* message) {
    if (value.is_null()) return;  // null means "default" in proto3 JSON.
    if (field->cpp_type() == gpb::FieldDescriptor::CPPTYPE_MESSAGE) {
      ReadMessage(value, path, message->GetReflection()->MutableMessage(message, field));
      return;
    }
    ReadScalar(value, path, field, message, /*add=*/false);
  }

  // Reads one scalar into `field`: set when singular, appended when `add`.
  void ReadScalar(const Json& value, const std::string& path, const gpb::FieldDescriptor* field,
                  gpb::Message* message, bool add) {
    const gpb::Reflection* r = message->GetReflection();
    switch (field->cpp_type()) {
      case gpb::FieldDescriptor::CPPTYPE_DOUBLE:
      case gpb::FieldDescriptor::CPPTYPE_FLOAT: {
        double number = 0;
        if (!ReadDouble(value, path, &number)) return;
        if (field->cpp_type() == gpb::FieldDescriptor::CPPTYPE_FLOAT) {
          add ? r->AddFloat(message, field, static_cast<float>(number))
              : r->SetFloat(message, field, static_cast<float>(number));
        } else {
          add ? r->AddDouble(message, field, number) : r->SetDouble(message, field, number);
        }
        return;
      }
      case gpb::FieldDescriptor::CPPTYPE_INT32:
      case gpb::FieldDescriptor::CPPTYPE_INT64:
      case gpb::FieldDescriptor::CPPTYPE_UINT32:
      case gpb::FieldDescriptor::CPPTYPE_UINT64:
        ReadInteger(value, path, field, message, add);
        return;
      case gpb::FieldDescriptor::CPPTYPE_BOOL:
        if (!value.is_boolean()) {
          Add(path, absl::StrCat("expected true or false, got ", Describe(value)));
          return;
        }
        add ? r->AddBool(message, field, value.get<bool>())
            : r->SetBool(message, field, value.get<bool>());
        return;
      case gpb::FieldDescriptor::CPPTYPE_STRING:
        if (!value.is_string()) {
          Add(path, absl::StrCat("expected a string, got ", Describe(value)));
          return;
        }
        add ? r->AddString(message, field, value.get<std::string>())
            : r->SetString(message, field, value.get<std::string>());
        return;
      case gpb::FieldDescriptor::CPPTYPE_ENUM:
        ReadEnum(value, path, field, message, add);
        return;
      case gpb::FieldDescriptor::CPPTYPE_MESSAGE:
        break;
    }
    Add(path, "unsupported field type");
  }

  bool ReadDouble(const Json& value, const std::string& path, double* number) {
    if (value.is_number()) {
      *number = value.get<double>();
      return true;
    }
    if (value.is_string()) {
      const std::string& text = value.get_ref<const std::string&>();
      if (text == kNaN) {
        *number = std::numeric_limits<double>::quiet_NaN();
        return true;
      }
      if (text == kInfinity || text == kMinusInfinity) {
        *number = text == kInfinity ? std::numeric_limits<double>::infinity()
                                    : -std::numeric_limits<double>::infinity();
        return true;
      }
      Json parsed;
      if (ParseJsonNumber(text, &parsed)) {
        *number = parsed.get<double>();
        return true;
      }
    }
    Add(path, absl::StrCat("expected a number, got ", Describe(value)));
    return false;
  }

  void ReadInteger(const Json& value, const std::string& path, const gpb::FieldDescriptor* field,
                   gpb::Message* message, bool add) {
    // Accept a JSON integer, an integral float, or a decimal string of one.
    Json number = value;
    if (value.is_string() && !ParseJsonNumber(value.get<std::string>(), &number)) {
      number = nullptr;
    }
    __int128 v = 0;  // Wide enough for every int32/int64/uint32/uint64 value.
    bool ok = true;
    if (number.is_number_unsigned()) {
      v = number.get<uint64_t>();
    } else if (number.is_number_integer()) {
      v = number.get<int64_t>();
    } else if (number.is_number_float()) {
      const double d = number.get<double>();
      ok = std::isfinite(d) && d == std::floor(d);
      if (ok && std::abs(d) > 0x1p100) {  // Integral, but far out of any range.
        Add(path, absl::StrCat("integer ", number.dump(), " is out of range for ",
                               field->cpp_type_name()));
        return;
      }
      if (ok) v = static_cast<__int128>(d);
    } else {
      ok = false;
    }
    if (!ok) {
      Add(path, absl::StrCat("expected an integer, got ", Describe(value)));
      return;
    }
    __int128 min = 0, max = 0;
    switch (field->cpp_type()) {
      case gpb::FieldDescriptor::CPPTYPE_INT32:
        min = std::numeric_limits<int32_t>::min();
        max = std::numeric_limits<int32_t>::max();
        break;
      case gpb::FieldDescriptor::CPPTYPE_INT64:
        min = std::numeric_limits<int64_t>::min();
        max = std::numeric_limits<int64_t>::max();
        break;
      case gpb::FieldDescriptor::CPPTYPE_UINT32:
        max = std::numeric_limits<uint32_t>::max();
        break;
      default:
        max = std::numeric_limits<uint64_t>::max();
        break;
    }
    if (v < min || v > max) {
      Add(path,
          absl::StrCat("integer ", number.dump(), " is out of range for ", field->cpp_type_name()));
      return;
    }
    const gpb::Reflection* r = message->GetReflection();
    switch (field->cpp_type()) {
      case gpb::FieldDescriptor::CPPTYPE_INT32:
        add ? r->AddInt32(message, field, static_cast<int32_t>(v))
            : r->SetInt32(message, field, static_cast<int32_t>(v));
        break;
      case gpb::FieldDescriptor::CPPTYPE_INT64:
        add ? r->AddInt64(message, field, static_cast<int64_t>(v))
            : r->SetInt64(message, field, static_cast<int64_t>(v));
        break;
      case gpb::FieldDescriptor::CPPTYPE_UINT32:
        add ? r->AddUInt32(message, field, static_cast<uint32_t>(v))
            : r->SetUInt32(message, field, static_cast<uint32_t>(v));
        break;
      default:
        add ? r->AddUInt64(message, field, static_cast<uint64_t>(v))
            : r->SetUInt64(message, field, static_cast<uint64_t>(v));
        break;
    }
  }

  void ReadEnum(const Json& value, const std::string& path, const gpb::FieldDescriptor* field,
                gpb::Message* message, bool add) {
    const gpb::EnumDescriptor* type = field->enum_type();
    const gpb::EnumValueDescriptor* found = nullptr;
    if (value.is_string()) {
      found = type->FindValueByName(value.get<std::string>());
    } else if (value.is_number_integer() || value.is_number_unsigned()) {
      const int64_t number = value.get<int64_t>();
      if (number >= std::numeric_limits<int32_t>::min() &&
          number <= std::numeric_limits<int32_t>::max()) {
        found = type->FindValueByNumber(static_cast<int>(number));
      }
    }
    if (found == nullptr) {
      std::vector<std::string> names;
      for (int i = 0; i < type->value_count(); ++i) names.push_back(type->value(i)->name());
      Add(path, absl::StrCat("unknown ", type->name(), " value ", value.dump(),
                             " (expected one of ", absl::StrJoin(names, ", "), ")"));
      return;
    }
    const gpb::Reflection* r = message->GetReflection();
    add ? r->AddEnumValue(message, field, found->number())
        : r->SetEnumValue(message, field, found->number());
  }

  std::vector<ClipProblem>* problems_;
};

// Returns the JSON of a double: a number, or the proto3 JSON strings for
// non-finite values.
Json DoubleToJson(double value) {
  if (std::isnan(value)) return kNaN;
  if (std::isinf(value)) return value > 0 ? kInfinity : kMinusInfinity;
  return value;
}

Json ScalarToJson(const gpb::Message& message, const gpb::FieldDescriptor* field, int index) {
  const gpb::Reflection* r = message.GetReflection();
  const bool repeated = index >= 0;
  switch (field->cpp_type()) {
    case gpb::FieldDescriptor::CPPTYPE_DOUBLE:
      return DoubleToJson(repeated ? r->GetRepeatedDouble(message, field, index)
                                   : r->GetDouble(message, field));
    case gpb::FieldDescriptor::CPPTYPE_FLOAT:
      return DoubleToJson(repeated ? r->GetRepeatedFloat(message, field, index)
                                   : r->GetFloat(message, field));
    case gpb::FieldDescriptor::CPPTYPE_INT32:
      return repeated ? r->GetRepeatedInt32(message, field, index) : r->GetInt32(message, field);
    case gpb::FieldDescriptor::CPPTYPE_INT64:
      return repeated ? r->GetRepeatedInt64(message, field, index) : r->GetInt64(message, field);
    case gpb::FieldDescriptor::CPPTYPE_UINT32:
      return repeated ? r->GetRepeatedUInt32(message, field, index) : r->GetUInt32(message, field);
    case gpb::FieldDescriptor::CPPTYPE_UINT64:
      return repeated ? r->GetRepeatedUInt64(message, field, index) : r->GetUInt64(message, field);
    case gpb::FieldDescriptor::CPPTYPE_BOOL:
      return repeated ? r->GetRepeatedBool(message, field, index) : r->GetBool(message, field);
    case gpb::FieldDescriptor::CPPTYPE_STRING:
      return repeated ? r->GetRepeatedString(message, field, index) : r->GetString(message, field);
    case gpb::FieldDescriptor::CPPTYPE_ENUM: {
      const gpb::EnumValueDescriptor* value =
          repeated ? r->GetRepeatedEnum(message, field, index) : r->GetEnum(message, field);
      return value->name();
    }
    case gpb::FieldDescriptor::CPPTYPE_MESSAGE:
      break;
  }
  return nullptr;
}

// Converts `message` to JSON in proto field order, leaving out fields at
// their default value (proto3 presence).
Json MessageToJson(const gpb::Message& message) {
  Json object = Json::object();
  const gpb::Reflection* r = message.GetReflection();
  std::vector<const gpb::FieldDescriptor*> fields;
  r->ListFields(message, &fields);
  for (const gpb::FieldDescriptor* field : fields) {
    const bool is_message = field->cpp_type() == gpb::FieldDescriptor::CPPTYPE_MESSAGE;
    if (field->is_repeated()) {
      Json array = Json::array();
      for (int i = 0; i < r->FieldSize(message, field); ++i) {
        array.push_back(is_message ? MessageToJson(r->GetRepeatedMessage(message, field, i))
                                   : ScalarToJson(message, field, i));
      }
      object[field->json_name()] = std::move(array);
    } else {
      object[field->json_name()] = is_message ? MessageToJson(r->GetMessage(message, field))
                                              : ScalarToJson(message, field, -1);
    }
  }
  return object;
}

// Appends `value` as indented JSON; arrays of scalars stay on one line.
void PrettyPrint(const Json& value, int indent, std::string* out) {
  const std::string pad(indent + 2, ' ');
  if (value.is_object() && !value.empty()) {
    out->append("{\n");
    size_t i = 0;
    for (const auto& [key, child] : value.items()) {
      absl::StrAppend(out, pad, Json(key).dump(), ": ");
      PrettyPrint(child, indent + 2, out);
      out->append(++i < value.size() ? ",\n" : "\n");
    }
    absl::StrAppend(out, std::string(indent, ' '), "}");
    return;
  }
  if (value.is_array() && !value.empty()) {
    bool flat = true;
    for (const Json& item : value) flat = flat && item.is_primitive();
    if (flat) {
      out->append("[");
      for (size_t i = 0; i < value.size(); ++i) {
        absl::StrAppend(out, i > 0 ? ", " : "", value[i].dump());
      }
      out->append("]");
      return;
    }
    out->append("[\n");
    for (size_t i = 0; i < value.size(); ++i) {
      out->append(pad);
      PrettyPrint(value[i], indent + 2, out);
      out->append(i + 1 < value.size() ? ",\n" : "\n");
    }
    absl::StrAppend(out, std::string(indent, ' '), "]");
    return;
  }
  out->append(value.dump());
}

// Returns INVALID_ARGUMENT listing `problems`, one per line.
absl::Status ProblemsToStatus(const std::vector<ClipProblem>& problems) {
  std::vector<std::string> lines;
  for (const ClipProblem& problem : problems) lines.push_back(problem.ToString());
  return absl::InvalidArgumentError(absl::StrJoin(lines, "\n"));
}

}  // namespace

std::string ClipProblem::ToString() const {
  return field.empty() ? message : absl::StrCat(field, ": ", message);
}

absl::Status ParseJsonMessage(const std::string& json, google::protobuf::Message* message,
                              std::vector<ClipProblem>* problems) {
  std::vector<ClipProblem> found;
  std::vector<std::string> duplicate_keys;
  absl::StatusOr<Json> root = ParseBoundedJson(json, JsonLimits{}, &duplicate_keys);
  if (!root.ok()) {
    found.push_back({"", std::string(root.status().message())});
  } else {
    for (std::string& path : duplicate_keys) {
      found.push_back({std::move(path), "key given twice in one object"});
    }
    if (!root->is_object()) {
      found.push_back(
          {"", absl::StrCat("expected a JSON object at the top level, got ", Describe(*root))});
    } else {
      ManifestReader(&found).ReadMessage(*root, "", message);
    }
  }
  if (problems != nullptr) problems->insert(problems->end(), found.begin(), found.end());
  return found.empty() ? absl::OkStatus() : ProblemsToStatus(found);
}

absl::StatusOr<LoadedClip> ParseClip(const std::string& json, const std::string& dir,
                                     std::vector<ClipProblem>* problems) {
  LoadedClip loaded;
  std::error_code ec;  // fs::absolute fails only without a working directory.
  loaded.dir = fs::absolute(dir.empty() ? "." : dir, ec).lexically_normal().string();
  if (loaded.dir.size() > 1 && loaded.dir.back() == '/') loaded.dir.pop_back();
  RETURN_IF_ERROR(ParseJsonMessage(json, &loaded.clip, problems));
  return loaded;
}

absl::StatusOr<LoadedClip> LoadClip(const std::string& path, std::vector<ClipProblem>* problems) {
  absl::StatusOr<std::string> text = ReadFileToString(path);
  if (!text.ok()) {
    if (problems != nullptr) problems->push_back({"", std::string(text.status().message())});
    return text.status();
  }
  const std::string dir = fs::path(path).parent_path().string();
  absl::StatusOr<LoadedClip> loaded = ParseClip(*text, dir, problems);
  if (!loaded.ok()) return StatusWithContext(loaded.status(), path);
  return loaded;
}

std::string ClipToJson(const pointforward::v1::Clip& clip) {
  std::string out;
  PrettyPrint(MessageToJson(clip), 0, &out);
  out.push_back('\n');
  return out;
}

absl::Status SaveClip(const pointforward::v1::Clip& clip, const std::string& path) {
  return WriteFileAtomic(path, ClipToJson(clip));
}

std::vector<ClipFileRef> ReferencedFiles(const pointforward::v1::Clip& clip) {
  std::vector<ClipFileRef> refs;
  std::set<std::string> seen;
  auto add = [&](std::string field, const std::string& path) {
    if (!path.empty() && seen.insert(path).second) refs.push_back({std::move(field), path});
  };
  for (int i = 0; i < clip.cameras_size(); ++i) {
    add(absl::StrCat("cameras[", i, "].egoMask"), clip.cameras(i).ego_mask());
  }
  for (int i = 0; i < clip.frames_size(); ++i) {
    add(absl::StrCat("frames[", i, "].image"), clip.frames(i).image());
    add(absl::StrCat("frames[", i, "].depth"), clip.frames(i).depth());
  }
  for (int i = 0; i < clip.lidar_size(); ++i) {
    add(absl::StrCat("lidar[", i, "].points"), clip.lidar(i).points());
  }
  return refs;
}

}  // namespace pf
