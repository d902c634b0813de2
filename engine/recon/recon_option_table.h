// The options of a reconstruction, defined once: each option's flag, its
// field of pointforward.v1.ReconstructionOptions, its values (choices or a
// range) and its place in the scene cache key. Every path in takes the same
// table: the command line (`pf reconstruct`, `pf eval`, `pf scene create`),
// the server's intake and cache key, and the worker (through
// ReconOptionsFromProto, recon_options.h, which makes the engine's
// ReconOptions). Needs no engine code: the server links it alone.
//
//   ASSIGN_OR_RETURN(pb::ReconstructionOptions proto,
//                    ReconProtoFromFlags(cl, BuiltInReconModelNames()));
//   ASSIGN_OR_RETURN(proto, NormalizeReconProto(proto, BuiltInReconModelNames()));
#ifndef POINTFORWARD_ENGINE_RECON_RECON_OPTION_TABLE_H_
#define POINTFORWARD_ENGINE_RECON_RECON_OPTION_TABLE_H_

#include <set>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/statusor.h"
#include "common/command_line.h"
#include "pointforward/v1/resources.pb.h"

namespace pf {

struct ReconOptionSpec {
  enum class Kind {
    kModel,   // A model's name (recon_model.h); checked against the names given.
    kChoice,  // One of `choices`.
    kDevice,  // "cpu" or "cuda:N" (compute_device.h).
    kInt,     // An integer in [lo, hi] (lo excluded when lo_open).
    kReal,    // A number in [lo, hi].
    kSwitch,  // A flag without a value; a bool field.
  };
  // How the option enters the scene cache key (SceneCacheKeyFields).
  enum class Key {
    kNone,             // Not part of it (the device, a switch meaning the default).
    kText,             // Always: the value as text.
    kTextWhenSet,      // When set: the value as text.
    kHexWhenSet,       // When set: the double exactly ("%a").
    kHexFloatWhenSet,  // When set: the value as a float, exactly (what the scene stores).
    kOnOff,            // Always: "on" or "off".
    kOffWhenSet,       // "off" when the switch is set (it turns a default step off).
    kOnWhenSet,        // "on" when the switch is set (it turns a step on).
  };
  const char* field;  // ReconstructionOptions field: "splat_sigma" (flag --splat-sigma).
  Kind kind;
  const char* what = "";             // kChoice, in errors: "unknown weighting 'x'".
  std::vector<std::string> choices;  // kChoice: the first is the default.
  double lo = 0;
  bool lo_open = false;
  double hi = 0;
  const char* unit = "";  // After the range in errors: " pixels".
  Key key = Key::kNone;
  const char* key_name = "";   // In the key, when not `field`.
  bool fills_default = false;  // Unset is set to the default (the first model or choice).
  const char* conflicts = "";  // A switch that must not be set with this one.
  const char* needs = "";      // A field that must be set (non-zero) with this one.
  bool clear_default = false;  // A value equal to the default is cleared (one key).
};

// Every option, in the order the cache key lists them.
const std::vector<ReconOptionSpec>& ReconOptionTable();

// The names of the models built in (models/model_list.h), in order.
std::vector<std::string> BuiltInReconModelNames();

// An option's flag without "--": its field with '-' for '_' ("splat-sigma").
std::string ReconOptionFlag(const ReconOptionSpec& spec);

// OK when `name` is one of `models`; else INVALID_ARGUMENT "`field`: unknown
// model 'x' (expected analytic or pixel-aligned)".
absl::Status CheckModelName(const std::string& name, const std::vector<std::string>& models,
                            const std::string& field);

// The flags of the table, for CommandLine::Parse: those with a value and the switches.
std::set<std::string> ReconValueFlags();
std::set<std::string> ReconSwitchFlags();

// The options the flags of `cl` give, each checked against its range or
// choices; INVALID_ARGUMENT naming the flag ("--refine: must be in [0, 64]
// iterations, got 65"). `models` are the names --model may take.
absl::StatusOr<pointforward::v1::ReconstructionOptions> ReconProtoFromFlags(
    const CommandLine& cl, const std::vector<std::string>& models);

// Checks every field that is set against its range or choices, naming it
// ("options.refine: ..."), and fills the defaults the key needs (model,
// fusion, device) and clears what equals a default, so that two requests for
// the same scene read the same. INVALID_ARGUMENT for a bad value or two
// switches that conflict.
absl::StatusOr<pointforward::v1::ReconstructionOptions> NormalizeReconProto(
    const pointforward::v1::ReconstructionOptions& options, const std::vector<std::string>& models);

// The (name, value) pairs of normalised `options` that the scene cache key
// hashes, in table order.
std::vector<std::pair<std::string, std::string>> SceneCacheKeyFields(
    const pointforward::v1::ReconstructionOptions& options);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RECON_RECON_OPTION_TABLE_H_
