// The ranges of a reconstruction's tuning values, in one place for the
// flags of `pf reconstruct` / `pf eval` (recon_flags.h) and the service's
// ReconstructionOptions (server/clip_intake.h, worker/task_runner.h).
// Header-only: the server checks requests without linking the engine.
//
//   RETURN_IF_ERROR(CheckTuning(kRefineLimit, value));  // "--refine: must be ..."
#ifndef POINTFORWARD_WORKER_ENGINE_RECON_TUNING_LIMITS_H_
#define POINTFORWARD_WORKER_ENGINE_RECON_TUNING_LIMITS_H_

#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "worker/engine/render/gaussian_scene.h"

namespace pf {

struct TuningLimit {
  const char* flag;   // As the command line spells it: "--refine".
  const char* field;  // As ReconstructionOptions spells it: "refine".
  double lo;
  bool lo_open;  // (lo, hi] instead of [lo, hi].
  double hi;
  const char* unit;  // After the range: " iterations".
};

inline constexpr TuningLimit kSplatSigmaLimit{"--splat-sigma", "splat_sigma", 0.05, true, 4, ""};
inline constexpr TuningLimit kLowPassLimit{"--low-pass", "low_pass",  0,
                                           false,        kMaxLowPass, " pixels^2"};
inline constexpr TuningLimit kRefineLimit{"--refine", "refine", 0, false, 64, " iterations"};
inline constexpr TuningLimit kHiddenBandLimit{"--hidden-band", "hidden_band", 0,
                                              false,           256,           " pixels"};

// Returns "" when `value` is within `limit`, else what is wrong with it
// ("must be in [0, 64] iterations, got 65"). NaN is never within.
inline std::string TuningProblem(const TuningLimit& limit, double value) {
  const bool above_lo = limit.lo_open ? value > limit.lo : value >= limit.lo;
  if (above_lo && value <= limit.hi) return "";
  return absl::StrCat("must be in ", limit.lo_open ? "(" : "[", limit.lo, ", ", limit.hi, "]",
                      limit.unit, ", got ", value);
}

// Returns INVALID_ARGUMENT "`name`: must be in ..." unless `value` is within
// `limit`; `name` is the flag (limit.flag) unless given.
inline absl::Status CheckTuning(const TuningLimit& limit, double value,
                                const std::string& name = "") {
  const std::string problem = TuningProblem(limit, value);
  if (problem.empty()) return absl::OkStatus();
  return absl::InvalidArgumentError(
      absl::StrCat(name.empty() ? std::string(limit.flag) : name, ": ", problem));
}

// Parses a colour model as --colour and ReconstructionOptions.colour spell
// it: "gradients" (true) or "flat" (false); INVALID_ARGUMENT naming `name`
// otherwise.
inline absl::StatusOr<bool> ParseColourModel(const std::string& value, const std::string& name) {
  if (value == "gradients") return true;
  if (value == "flat") return false;
  return absl::InvalidArgumentError(
      absl::StrCat(name, ": unknown colour model '", value, "' (expected gradients or flat)"));
}

// Checks the tuning fields that are set in a ReconstructionOptions message
// (a template so that this header needs no generated code), naming the
// field: "options.refine: must be in [0, 64] iterations, got 65"; the colour
// model must be empty, "gradients" or "flat".
template <typename ReconstructionOptions>
absl::Status CheckTuningFields(const ReconstructionOptions& options) {
  auto check = [](const TuningLimit& limit, bool set, double value) {
    return set ? CheckTuning(limit, value, absl::StrCat("options.", limit.field))
               : absl::OkStatus();
  };
  absl::Status status = check(kRefineLimit, options.has_refine(), options.refine());
  if (status.ok())
    status = check(kSplatSigmaLimit, options.has_splat_sigma(), options.splat_sigma());
  if (status.ok()) status = check(kLowPassLimit, options.has_low_pass(), options.low_pass());
  if (status.ok())
    status = check(kHiddenBandLimit, options.has_hidden_band(), options.hidden_band());
  if (status.ok() && !options.colour().empty()) {
    status = ParseColourModel(options.colour(), "options.colour").status();
  }
  return status;
}

}  // namespace pf

#endif  // POINTFORWARD_WORKER_ENGINE_RECON_TUNING_LIMITS_H_
