// JSON field access that names the field instead of throwing.
#include "engine/importers/json_fields.h"

#include <cmath>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "common/bounded_json.h"
#include "common/file_util.h"
#include "common/status_macros.h"

namespace pf {

absl::StatusOr<Json> LoadJson(const std::string& path) {
  ASSIGN_OR_RETURN(std::string text, ReadFileToString(path));
  absl::StatusOr<Json> j = ParseBoundedJson(text, {.max_bytes = int64_t{1} << 30});
  if (!j.ok()) return StatusWithContext(j.status(), path);
  return j;
}

absl::StatusOr<const Json*> JsonMember(const Json& j, const std::string& key,
                                       const std::string& where) {
  if (!j.is_object()) return absl::InvalidArgumentError(absl::StrCat(where, ": not an object"));
  const auto it = j.find(key);
  if (it == j.end()) {
    return absl::InvalidArgumentError(absl::StrCat(where, ".", key, ": missing"));
  }
  return &*it;
}

absl::StatusOr<double> JsonNumber(const Json& j, const std::string& key, const std::string& where) {
  ASSIGN_OR_RETURN(const Json* v, JsonMember(j, key, where));
  if (!v->is_number())
    return absl::InvalidArgumentError(absl::StrCat(where, ".", key, ": not a number"));
  const double d = v->get<double>();
  if (!std::isfinite(d))
    return absl::InvalidArgumentError(absl::StrCat(where, ".", key, ": not finite"));
  return d;
}

absl::StatusOr<std::string> JsonString(const Json& j, const std::string& key,
                                       const std::string& where) {
  ASSIGN_OR_RETURN(const Json* v, JsonMember(j, key, where));
  if (!v->is_string())
    return absl::InvalidArgumentError(absl::StrCat(where, ".", key, ": not a string"));
  return v->get<std::string>();
}

absl::StatusOr<const Json*> JsonArray(const Json& j, const std::string& key,
                                      const std::string& where) {
  ASSIGN_OR_RETURN(const Json* v, JsonMember(j, key, where));
  if (!v->is_array())
    return absl::InvalidArgumentError(absl::StrCat(where, ".", key, ": not an array"));
  return v;
}

absl::StatusOr<Rigid> JsonPose(const Json& pose, const JsonPoseKeys& keys, const std::string& where,
                               double tolerance) {
  ASSIGN_OR_RETURN(const Json* r, JsonMember(pose, keys.rotation, where));
  ASSIGN_OR_RETURN(const Json* t, JsonMember(pose, keys.translation, where));
  const std::string rw = absl::StrCat(where, ".", keys.rotation);
  const std::string tw = absl::StrCat(where, ".", keys.translation);
  Quat q;
  ASSIGN_OR_RETURN(q.w, JsonNumber(*r, keys.w, rw));
  ASSIGN_OR_RETURN(q.x, JsonNumber(*r, keys.x, rw));
  ASSIGN_OR_RETURN(q.y, JsonNumber(*r, keys.y, rw));
  ASSIGN_OR_RETURN(q.z, JsonNumber(*r, keys.z, rw));
  if (std::abs(QuatNorm(q) - 1.0) > tolerance) {
    return absl::InvalidArgumentError(
        absl::StrCat(rw, ": not a unit quaternion (norm ", QuatNorm(q), ")"));
  }
  Rigid out;
  out.rotation = ToMatrix(QuatNormalized(q));
  ASSIGN_OR_RETURN(out.translation.x, JsonNumber(*t, "x", tw));
  ASSIGN_OR_RETURN(out.translation.y, JsonNumber(*t, "y", tw));
  ASSIGN_OR_RETURN(out.translation.z, JsonNumber(*t, "z", tw));
  return out;
}

}  // namespace pf
