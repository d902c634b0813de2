// synth.json: the generator parameters `pf synth` records beside a clip, so
// that `pf synth render` can regenerate exactly the same scene. A small JSON
// object:
//
//   {"generator": "pf synth", "version": 1, "seed": 7, "cameras": 3,
//    "frames": 20, "width": 768, "height": 576, "antialias": 2}
//
// and "lens": "ftheta" for f-theta cameras (absent: pinhole).
#ifndef POINTFORWARD_ENGINE_SYNTH_SYNTH_PARAMS_H_
#define POINTFORWARD_ENGINE_SYNTH_SYNTH_PARAMS_H_

#include <string>

#include "absl/status/statusor.h"
#include "engine/synth/synth_scene.h"

namespace pf {

// "pinhole" or "ftheta"; INVALID_ARGUMENT naming "lens" otherwise.
absl::StatusOr<SynthLens> SynthLensFromName(const std::string& name);

// Returns the synth.json text for `options` (with kSynthVersion).
std::string SynthParamsToJson(const SynthOptions& options);

// Parses synth.json text. INVALID_ARGUMENT prefixed with `where` (the file
// name) for malformed JSON, a missing, unknown or non-integer field, or
// options out of range; FAILED_PRECONDITION for another generator version.
absl::StatusOr<SynthOptions> SynthParamsFromJson(const std::string& json, const std::string& where);

// Reads and parses the synth.json at `path`.
absl::StatusOr<SynthOptions> ReadSynthParams(const std::string& path);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_SYNTH_SYNTH_PARAMS_H_
