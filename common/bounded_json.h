// Parsing JSON that comes from outside the process (a user's manifest or
// views, a worker's result, a row read back from the job store) with bounds
// on its size and nesting, so no input can exhaust the stack or take time
// beyond linear in its size. Every parser of outside JSON goes through here:
// nlohmann trees through ParseBoundedJson, protobuf's JSON parser through
// ParseBoundedProtoJson.
//
//   ASSIGN_OR_RETURN(nlohmann::ordered_json views, ParseBoundedJson(text));
//   RETURN_IF_ERROR(ParseBoundedProtoJson(stored, &scene));
//
// The parse is iterative (no recursion per level) and builds the tree in one
// pass: objects are filled by appending, duplicate keys found through a hash
// of each open object's keys.
#ifndef POINTFORWARD_COMMON_BOUNDED_JSON_H_
#define POINTFORWARD_COMMON_BOUNDED_JSON_H_

#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace google::protobuf {
class Message;
}

namespace pf {

struct JsonLimits {
  int64_t max_bytes = int64_t{64} << 20;  // Size of the text.
  int max_depth = 64;                     // Objects and arrays open at once.
};

// Limits for JSON this service wrote itself and reads back (job store rows):
// only the nesting matters, the size is whatever the service accepted.
inline constexpr JsonLimits kStoredJsonLimits{int64_t{1} << 40, 64};

// Parses `text` as one JSON value. INVALID_ARGUMENT when it is larger than
// `limits.max_bytes` ("JSON of N bytes exceeds the limit of M bytes"),
// nested deeper than `limits.max_depth` ("JSON nested deeper than 64
// levels"), or malformed ("malformed JSON: parse error at line L, column C:
// ..."). When `duplicate_keys` is non-null, the path of every key given
// twice in one object is appended to it ("frames[2].image"; the later value
// wins, in the place of the first).
absl::StatusOr<nlohmann::ordered_json> ParseBoundedJson(
    std::string_view text, const JsonLimits& limits = {},
    std::vector<std::string>* duplicate_keys = nullptr);

// Checks `text` against `limits` as ParseBoundedJson does, building nothing.
absl::Status CheckBoundedJson(std::string_view text, const JsonLimits& limits = {});

// Checks `text` against `limits` (CheckBoundedJson), then parses it into
// `message` with protobuf's proto3 JSON parser (unknown fields refused
// unless `ignore_unknown_fields`). INVALID_ARGUMENT with the parser's message
// otherwise.
absl::Status ParseBoundedProtoJson(std::string_view text, google::protobuf::Message* message,
                                   const JsonLimits& limits = {},
                                   bool ignore_unknown_fields = false);

}  // namespace pf

#endif  // POINTFORWARD_COMMON_BOUNDED_JSON_H_
