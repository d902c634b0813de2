// The table of reconstruction options and its conversions: see
// recon_option_table.h.
#include "engine/recon/recon_option_table.h"

#include <algorithm>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "common/compute_device.h"
#include "common/status_macros.h"
#include "engine/recon/models/model_list.h"
#include "engine/render/gaussian_scene.h"

namespace pf {
namespace {

namespace v1 = pointforward::v1;
using google::protobuf::FieldDescriptor;
using Spec = ReconOptionSpec;
using Kind = ReconOptionSpec::Kind;
using Key = ReconOptionSpec::Key;

Spec Choice(const char* field, const char* what, std::vector<std::string> choices, Key key) {
  Spec spec{field, Kind::kChoice};
  spec.what = what;
  spec.choices = std::move(choices);
  spec.key = key;
  return spec;
}

Spec Number(const char* field, Kind kind, double lo, bool lo_open, double hi, const char* unit,
            Key key) {
  Spec spec{field, kind};
  spec.lo = lo;
  spec.lo_open = lo_open;
  spec.hi = hi;
  spec.unit = unit;
  spec.key = key;
  return spec;
}

Spec Switch(const char* field, Key key, const char* key_name = "") {
  Spec spec{field, Kind::kSwitch};
  spec.key = key;
  spec.key_name = key_name;
  return spec;
}

std::vector<Spec> MakeTable() {
  std::vector<Spec> table;
  Spec model{"model", Kind::kModel};
  model.key = Key::kText;
  model.fills_default = true;
  table.push_back(model);
  table.push_back(Number("ns", Kind::kInt, 1, false, 1e9, " queries per view", Key::kText));
  table.push_back(Number("nd", Kind::kInt, 1, false, 1e9, " queries per instance", Key::kText));
  table.push_back(
      Number("still_rig_density", Kind::kReal, 1, false, 16, " x N_s", Key::kHexWhenSet));
  Spec fusion = Choice("fusion", "weighting", {"softmax", "average", "no-depth"}, Key::kText);
  fusion.fills_default = true;
  table.push_back(fusion);
  table.push_back(Switch("lifespan", Key::kOnOff));
  Spec no_lifespan = Switch("no_lifespan", Key::kNone);
  no_lifespan.conflicts = "lifespan";
  no_lifespan.clear_default = true;  // The default: one key for both ways of asking.
  table.push_back(no_lifespan);
  table.push_back(Number("refine", Kind::kInt, 0, false, 64, " iterations", Key::kTextWhenSet));
  table.push_back(Number("splat_sigma", Kind::kReal, 0.05, true, 4, "", Key::kHexWhenSet));
  table.push_back(
      Number("low_pass", Kind::kReal, 0, false, kMaxLowPass, " pixels^2", Key::kHexFloatWhenSet));
  table.push_back(Number("hidden_band", Kind::kInt, 0, false, 256, " pixels", Key::kTextWhenSet));
  table.push_back(Number("colour_fit_memory", Kind::kReal, 0, true, 1e4, " GB", Key::kHexWhenSet));
  table.push_back(Switch("no_ground_fill", Key::kOffWhenSet, "ground_fill"));
  table.push_back(Switch("no_facades", Key::kOffWhenSet, "facades"));
  table.push_back(Switch("no_stereo", Key::kOffWhenSet, "stereo"));
  table.push_back(Choice("colour", "colour model", {"gradients", "flat"}, Key::kTextWhenSet));
  Spec completion = Choice("completion", "method", {"nearest", "ip-basic"}, Key::kTextWhenSet);
  completion.clear_default = true;
  table.push_back(completion);
  Spec working_space =
      Choice("working_space", "working space", {"srgb", "linear"}, Key::kTextWhenSet);
  working_space.clear_default = true;
  table.push_back(working_space);
  table.push_back(Number("optimize_steps", Kind::kInt, 0, false, 1e6, " steps", Key::kTextWhenSet));
  table.push_back(
      Number("optimize_seconds", Kind::kReal, 0, false, 604800, " seconds", Key::kHexWhenSet));
  Spec optimize_poses = Switch("optimize_poses", Key::kOnWhenSet);
  optimize_poses.needs = "optimize_steps";
  table.push_back(optimize_poses);
  Spec optimize_densify = Switch("optimize_densify", Key::kOnWhenSet);
  optimize_densify.needs = "optimize_steps";
  table.push_back(optimize_densify);
  table.push_back(
      Number("order_band", Kind::kReal, 0, false, kMaxOrderBand, "", Key::kHexFloatWhenSet));
  table.push_back(Number("fade_frames", Kind::kReal, 0, false, 100, " frames", Key::kHexWhenSet));
  table.push_back(Switch("no_ego_layer", Key::kOffWhenSet, "ego_layer"));
  table.push_back(Number("render_blur", Kind::kReal, 0, false, kMaxRenderBlur, " pixels",
                         Key::kHexFloatWhenSet));
  table.push_back(Number("render_blur_growth", Kind::kReal, 0, false, kMaxRenderBlurGrowth,
                         " mrad/m", Key::kHexFloatWhenSet));
  Spec device{"device", Kind::kDevice};
  device.choices = {"cpu"};
  device.fills_default = true;
  table.push_back(device);
  return table;
}

const FieldDescriptor* FieldOf(const Spec& spec) {
  return v1::ReconstructionOptions::descriptor()->FindFieldByName(spec.field);
}

// A field's flag: '-' for '_'.
std::string FlagOf(const char* field) {
  std::string flag = field;
  std::replace(flag.begin(), flag.end(), '_', '-');
  return flag;
}

std::string JoinChoices(const std::vector<std::string>& choices) {
  if (choices.size() < 2) return choices.empty() ? "" : choices[0];
  return absl::StrCat(
      absl::StrJoin(std::vector<std::string>(choices.begin(), choices.end() - 1), ", "), " or ",
      choices.back());
}

// Whether `field` holds a value (proto3 optional: present; else not the zero value).
bool IsSet(const v1::ReconstructionOptions& options, const FieldDescriptor* field) {
  const auto* reflection = options.GetReflection();
  if (field->has_presence()) return reflection->HasField(options, field);
  switch (field->cpp_type()) {
    case FieldDescriptor::CPPTYPE_STRING:
      return !reflection->GetString(options, field).empty();
    case FieldDescriptor::CPPTYPE_BOOL:
      return reflection->GetBool(options, field);
    case FieldDescriptor::CPPTYPE_INT32:
      return reflection->GetInt32(options, field) != 0;
    case FieldDescriptor::CPPTYPE_INT64:
      return reflection->GetInt64(options, field) != 0;
    case FieldDescriptor::CPPTYPE_DOUBLE:
      return reflection->GetDouble(options, field) != 0;
    default:
      return false;
  }
}

double NumberOf(const v1::ReconstructionOptions& options, const FieldDescriptor* field) {
  const auto* reflection = options.GetReflection();
  switch (field->cpp_type()) {
    case FieldDescriptor::CPPTYPE_INT32:
      return reflection->GetInt32(options, field);
    case FieldDescriptor::CPPTYPE_INT64:
      return double(reflection->GetInt64(options, field));
    default:
      return reflection->GetDouble(options, field);
  }
}

std::string TextOf(const v1::ReconstructionOptions& options, const FieldDescriptor* field) {
  const auto* reflection = options.GetReflection();
  switch (field->cpp_type()) {
    case FieldDescriptor::CPPTYPE_STRING:
      return reflection->GetString(options, field);
    case FieldDescriptor::CPPTYPE_INT32:
      return absl::StrCat(reflection->GetInt32(options, field));
    case FieldDescriptor::CPPTYPE_INT64:
      return absl::StrCat(reflection->GetInt64(options, field));
    case FieldDescriptor::CPPTYPE_BOOL:
      return reflection->GetBool(options, field) ? "true" : "false";
    default:
      return absl::StrCat(reflection->GetDouble(options, field));
  }
}

// What is wrong with `value` for a number option, or "".
std::string RangeProblem(const Spec& spec, double value) {
  const bool above_lo = spec.lo_open ? value > spec.lo : value >= spec.lo;
  if (above_lo && value <= spec.hi) return "";
  const auto bound = [&](double v) {
    return spec.kind == Kind::kInt ? absl::StrCat(int64_t(v)) : absl::StrCat(v);
  };
  return absl::StrCat("must be in ", spec.lo_open ? "(" : "[", bound(spec.lo), ", ", bound(spec.hi),
                      "]", spec.unit, ", got ", value);
}

// Checks a text value of a model, choice or device option; `name` is the
// flag or field the errors name.
absl::Status CheckText(const Spec& spec, const std::string& value, const std::string& name,
                       const std::vector<std::string>& models) {
  switch (spec.kind) {
    case Kind::kModel:
      return CheckModelName(value, models, name);
    case Kind::kChoice:
      if (std::find(spec.choices.begin(), spec.choices.end(), value) != spec.choices.end()) {
        return absl::OkStatus();
      }
      return absl::InvalidArgumentError(absl::StrCat(name, ": unknown ", spec.what, " '", value,
                                                     "' (expected ", JoinChoices(spec.choices),
                                                     ")"));
    case Kind::kDevice:
      return ParseComputeDevice(value, name).status();
    default:
      return absl::OkStatus();
  }
}

}  // namespace

std::string ReconOptionFlag(const ReconOptionSpec& spec) { return FlagOf(spec.field); }

absl::Status CheckModelName(const std::string& name, const std::vector<std::string>& models,
                            const std::string& field) {
  if (std::find(models.begin(), models.end(), name) != models.end()) return absl::OkStatus();
  return absl::InvalidArgumentError(
      absl::StrCat(field, ": unknown model '", name, "' (expected ", JoinChoices(models), ")"));
}

const std::vector<ReconOptionSpec>& ReconOptionTable() {
  static const std::vector<ReconOptionSpec>* table = new std::vector<Spec>(MakeTable());
  return *table;
}

std::vector<std::string> BuiltInReconModelNames() {
#define PF_MODEL_NAME(name, make) name,
  return {PF_RECON_MODELS(PF_MODEL_NAME)};
#undef PF_MODEL_NAME
}

std::set<std::string> ReconValueFlags() {
  std::set<std::string> flags;
  for (const Spec& spec : ReconOptionTable()) {
    if (spec.kind != Kind::kSwitch) flags.insert(FlagOf(spec.field));
  }
  return flags;
}

std::set<std::string> ReconSwitchFlags() {
  std::set<std::string> flags;
  for (const Spec& spec : ReconOptionTable()) {
    if (spec.kind == Kind::kSwitch) flags.insert(FlagOf(spec.field));
  }
  return flags;
}

absl::StatusOr<v1::ReconstructionOptions> ReconProtoFromFlags(
    const CommandLine& cl, const std::vector<std::string>& models) {
  v1::ReconstructionOptions options;
  const auto* reflection = options.GetReflection();
  for (const Spec& spec : ReconOptionTable()) {
    const std::string flag = FlagOf(spec.field);
    if (!cl.Has(flag)) continue;
    const std::string name = absl::StrCat("--", flag);
    const FieldDescriptor* field = FieldOf(spec);
    switch (spec.kind) {
      case Kind::kSwitch:
        if (spec.conflicts[0] != '\0' && cl.Has(FlagOf(spec.conflicts))) {
          return absl::InvalidArgumentError(
              absl::StrCat("--", FlagOf(spec.conflicts), ": given with ", name, "; give one"));
        }
        if (spec.needs[0] != '\0' && !cl.Has(FlagOf(spec.needs))) {
          return absl::InvalidArgumentError(
              absl::StrCat(name, ": needs --", FlagOf(spec.needs), " too"));
        }
        reflection->SetBool(&options, field, true);
        break;
      case Kind::kInt: {
        ASSIGN_OR_RETURN(const int64_t value, cl.GetInt(flag, 0));
        if (const std::string problem = RangeProblem(spec, double(value)); !problem.empty()) {
          return absl::InvalidArgumentError(absl::StrCat(name, ": ", problem));
        }
        if (field->cpp_type() == FieldDescriptor::CPPTYPE_INT32) {
          reflection->SetInt32(&options, field, static_cast<int32_t>(value));
        } else {
          reflection->SetInt64(&options, field, value);
        }
        break;
      }
      case Kind::kReal: {
        ASSIGN_OR_RETURN(const double value, cl.GetDouble(flag, 0));
        if (const std::string problem = RangeProblem(spec, value); !problem.empty()) {
          return absl::InvalidArgumentError(absl::StrCat(name, ": ", problem));
        }
        reflection->SetDouble(&options, field, value);
        break;
      }
      default: {
        const std::string value = cl.Get(flag);
        RETURN_IF_ERROR(CheckText(spec, value, name, models));
        reflection->SetString(&options, field, value);
      }
    }
  }
  return options;
}

absl::StatusOr<v1::ReconstructionOptions> NormalizeReconProto(
    const v1::ReconstructionOptions& options, const std::vector<std::string>& models) {
  v1::ReconstructionOptions out = options;
  const auto* reflection = out.GetReflection();
  for (const Spec& spec : ReconOptionTable()) {
    const FieldDescriptor* field = FieldOf(spec);
    const std::string name = absl::StrCat("options.", spec.field);
    if (!IsSet(out, field)) {
      if (spec.fills_default) {
        reflection->SetString(&out, field,
                              spec.kind == Kind::kModel ? models.front() : spec.choices.front());
      }
      continue;
    }
    switch (spec.kind) {
      case Kind::kSwitch:
        if (spec.conflicts[0] != '\0' &&
            IsSet(out, out.GetDescriptor()->FindFieldByName(spec.conflicts))) {
          return absl::InvalidArgumentError(
              absl::StrCat("options.", spec.conflicts, ": set together with ", name, "; set one"));
        }
        if (spec.needs[0] != '\0') {
          const FieldDescriptor* needed = out.GetDescriptor()->FindFieldByName(spec.needs);
          if (!IsSet(out, needed) || NumberOf(out, needed) <= 0) {
            return absl::InvalidArgumentError(
                absl::StrCat(name, ": needs options.", spec.needs, " too (above 0)"));
          }
        }
        break;
      case Kind::kInt:
      case Kind::kReal:
        if (const std::string problem = RangeProblem(spec, NumberOf(out, field));
            !problem.empty()) {
          return absl::InvalidArgumentError(absl::StrCat(name, ": ", problem));
        }
        break;
      default:
        RETURN_IF_ERROR(CheckText(spec, TextOf(out, field), name, models));
        if (spec.kind == Kind::kChoice && spec.clear_default &&
            TextOf(out, field) == spec.choices.front()) {
          reflection->ClearField(&out, field);
        }
    }
    if (spec.kind == Kind::kSwitch && spec.clear_default) reflection->ClearField(&out, field);
  }
  return out;
}

std::vector<std::pair<std::string, std::string>> SceneCacheKeyFields(
    const v1::ReconstructionOptions& options) {
  std::vector<std::pair<std::string, std::string>> fields;
  for (const Spec& spec : ReconOptionTable()) {
    const FieldDescriptor* field = FieldOf(spec);
    const std::string name = spec.key_name[0] != '\0' ? spec.key_name : spec.field;
    const bool set = IsSet(options, field);
    switch (spec.key) {
      case Key::kNone:
        break;
      case Key::kText:
        fields.emplace_back(name, TextOf(options, field));
        break;
      case Key::kTextWhenSet:
        if (set) fields.emplace_back(name, TextOf(options, field));
        break;
      case Key::kHexWhenSet:
        if (set) fields.emplace_back(name, absl::StrFormat("%a", NumberOf(options, field)));
        break;
      case Key::kHexFloatWhenSet:
        if (set) {
          fields.emplace_back(
              name, absl::StrFormat("%a", double(static_cast<float>(NumberOf(options, field)))));
        }
        break;
      case Key::kOnOff:
        fields.emplace_back(name, set ? "on" : "off");
        break;
      case Key::kOffWhenSet:
        if (set) fields.emplace_back(name, "off");
        break;
      case Key::kOnWhenSet:
        if (set) fields.emplace_back(name, "on");
        break;
    }
  }
  return fields;
}

}  // namespace pf
