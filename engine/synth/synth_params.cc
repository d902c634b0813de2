// synth.json reading and writing (see synth_params.h). Reading goes through
// protobuf's JSON parser into a google.protobuf.Struct.
#include "engine/synth/synth_params.h"

#include <google/protobuf/struct.pb.h>

#include <algorithm>
#include <cmath>
#include <set>

#include "absl/strings/str_cat.h"
#include "common/bounded_json.h"
#include "common/file_util.h"
#include "common/status_macros.h"

namespace pf {
namespace {

constexpr char kGenerator[] = "pf synth";

// Reads integer field `name` of `fields` into `out`.
absl::Status GetInteger(const google::protobuf::Struct& params, const std::string& name,
                        const std::string& where, int64_t* out) {
  const auto it = params.fields().find(name);
  if (it == params.fields().end()) {
    return absl::InvalidArgumentError(absl::StrCat(where, ": ", name, ": missing"));
  }
  const google::protobuf::Value& value = it->second;
  const double number = value.number_value();
  if (value.kind_case() != google::protobuf::Value::kNumberValue || !std::isfinite(number) ||
      number != std::floor(number) || std::abs(number) > 9007199254740992.0) {
    return absl::InvalidArgumentError(absl::StrCat(where, ": ", name, ": not an integer"));
  }
  *out = static_cast<int64_t>(number);
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<SynthLens> SynthLensFromName(const std::string& name) {
  if (name == "pinhole") return SynthLens::kPinhole;
  if (name == "ftheta") return SynthLens::kFTheta;
  return absl::InvalidArgumentError(
      absl::StrCat("lens: must be \"pinhole\" or \"ftheta\", got \"", name, "\""));
}

std::string SynthParamsToJson(const SynthOptions& options) {
  // Written by hand for a fixed field order; read back through protobuf.
  return absl::StrCat(
      "{\n  \"generator\": \"", kGenerator, "\",\n  \"version\": ", kSynthVersion,
      ",\n  \"seed\": ", options.seed, ",\n  \"cameras\": ", options.num_cameras,
      ",\n  \"frames\": ", options.num_frames, ",\n  \"width\": ", options.width,
      ",\n  \"height\": ", options.height, ",\n  \"antialias\": ", options.antialias,
      options.lens == SynthLens::kFTheta ? ",\n  \"lens\": \"ftheta\"" : "", "\n}\n");
}

absl::StatusOr<SynthOptions> SynthParamsFromJson(const std::string& json,
                                                 const std::string& where) {
  google::protobuf::Struct params;
  if (const absl::Status parsed = ParseBoundedProtoJson(json, &params); !parsed.ok()) {
    return absl::InvalidArgumentError(absl::StrCat(where, ": malformed JSON: ", parsed.message()));
  }
  static const std::set<std::string> kKnown = {
      "generator", "version", "seed", "cameras", "frames", "width", "height", "antialias", "lens"};
  for (const auto& [name, value] : params.fields()) {
    if (kKnown.count(name) == 0) {
      return absl::InvalidArgumentError(absl::StrCat(where, ": ", name, ": unknown field"));
    }
  }
  const auto generator = params.fields().find("generator");
  if (generator == params.fields().end() || generator->second.string_value() != kGenerator) {
    return absl::InvalidArgumentError(
        absl::StrCat(where, ": generator: must be \"", kGenerator, "\""));
  }
  int64_t version, seed, cameras, frames, width, height, antialias;
  RETURN_IF_ERROR(GetInteger(params, "version", where, &version));
  if (version != kSynthVersion) {
    return absl::FailedPreconditionError(absl::StrCat(where, ": version: ", version,
                                                      " is not the generator version of this pf (",
                                                      kSynthVersion, ")"));
  }
  RETURN_IF_ERROR(GetInteger(params, "seed", where, &seed));
  RETURN_IF_ERROR(GetInteger(params, "cameras", where, &cameras));
  RETURN_IF_ERROR(GetInteger(params, "frames", where, &frames));
  RETURN_IF_ERROR(GetInteger(params, "width", where, &width));
  RETURN_IF_ERROR(GetInteger(params, "height", where, &height));
  RETURN_IF_ERROR(GetInteger(params, "antialias", where, &antialias));
  if (seed < 0) return absl::InvalidArgumentError(absl::StrCat(where, ": seed: negative"));
  // Clamp before narrowing so that out-of-range values reach the range check.
  auto narrow = [](int64_t v) { return static_cast<int>(std::clamp<int64_t>(v, -1, 1 << 30)); };
  SynthOptions options;
  options.seed = static_cast<uint64_t>(seed);
  options.num_cameras = narrow(cameras);
  options.num_frames = narrow(frames);
  options.width = narrow(width);
  options.height = narrow(height);
  options.antialias = narrow(antialias);
  // "lens": "pinhole" (when absent) or "ftheta".
  if (const auto lens = params.fields().find("lens"); lens != params.fields().end()) {
    absl::StatusOr<SynthLens> parsed_lens = SynthLensFromName(lens->second.string_value());
    if (!parsed_lens.ok()) return StatusWithContext(parsed_lens.status(), where);
    options.lens = *parsed_lens;
  }
  RETURN_IF_ERROR(StatusWithContext(ValidateSynthOptions(options), where));
  return options;
}

absl::StatusOr<SynthOptions> ReadSynthParams(const std::string& path) {
  ASSIGN_OR_RETURN(std::string json, ReadFileToString(path));
  return SynthParamsFromJson(json, path);
}

}  // namespace pf
