// Reading the JSON files of dataset layouts (DGP scenes, PandaSet sequences)
// without exceptions: each accessor names the field it wanted when the value
// is missing or of the wrong type.
#ifndef POINTFORWARD_ENGINE_IMPORTERS_JSON_FIELDS_H_
#define POINTFORWARD_ENGINE_IMPORTERS_JSON_FIELDS_H_

#include <nlohmann/json.hpp>
#include <string>

#include "absl/status/statusor.h"
#include "common/geometry.h"

namespace pf {

using Json = nlohmann::ordered_json;

// Parses the file at `path`; NOT_FOUND when missing, INVALID_ARGUMENT
// ("PATH: malformed JSON") when it does not parse.
absl::StatusOr<Json> LoadJson(const std::string& path);

// Returns `j[key]`; INVALID_ARGUMENT "WHERE.KEY: missing" (or "WHERE: not an
// object") otherwise. `where` names `j` in messages.
absl::StatusOr<const Json*> JsonMember(const Json& j, const std::string& key,
                                       const std::string& where);

// `j[key]` as a finite number, a string or an array; INVALID_ARGUMENT naming
// WHERE.KEY otherwise.
absl::StatusOr<double> JsonNumber(const Json& j, const std::string& key, const std::string& where);
absl::StatusOr<std::string> JsonString(const Json& j, const std::string& key,
                                       const std::string& where);
absl::StatusOr<const Json*> JsonArray(const Json& j, const std::string& key,
                                      const std::string& where);

// The member names of a pose object: a quaternion object and a translation
// object {x, y, z}.
struct JsonPoseKeys {
  const char* rotation;       // e.g. "rotation" (DGP), "heading" (PandaSet).
  const char *w, *x, *y, *z;  // The quaternion's members.
  const char* translation;    // e.g. "translation", "position".
};

// Reads a rigid pose {ROTATION: {W, X, Y, Z}, TRANSLATION: {x, y, z}} named by
// `keys`; the quaternion must have unit norm within `tolerance` (it is then
// normalised). INVALID_ARGUMENT naming the field otherwise.
absl::StatusOr<Rigid> JsonPose(const Json& pose, const JsonPoseKeys& keys, const std::string& where,
                               double tolerance = 1e-3);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_IMPORTERS_JSON_FIELDS_H_
