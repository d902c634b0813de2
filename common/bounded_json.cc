// Bounded JSON parsing: see bounded_json.h.
#include "common/bounded_json.h"

#include <google/protobuf/message.h>
#include <google/protobuf/util/json_util.h>

#include <exception>
#include <unordered_map>
#include <utility>

#include "absl/strings/str_cat.h"

namespace pf {
namespace {

using Json = nlohmann::ordered_json;

// nlohmann's message without its "[json.exception.parse_error.101] " id:
// "parse error at line L, column C: ...".
std::string ParseErrorMessage(const std::exception& e) {
  std::string what = e.what();
  const size_t start = what.find("] ");
  if (start != std::string::npos) what = what.substr(start + 2);
  return absl::StrCat("malformed JSON: ", what);
}

// nlohmann SAX events to a tree (when `build`), refusing a value nested
// deeper than `max_depth`. Each value is appended to the innermost open
// container; nothing is searched but the open object's hash of keys.
class BoundedSax {
 public:
  BoundedSax(int max_depth, bool build, std::vector<std::string>* duplicate_keys)
      : max_depth_(max_depth), build_(build), duplicate_keys_(duplicate_keys) {}

  bool null() { return Value(nullptr); }
  bool boolean(bool value) { return Value(value); }
  bool number_integer(Json::number_integer_t value) { return Value(value); }
  bool number_unsigned(Json::number_unsigned_t value) { return Value(value); }
  bool number_float(Json::number_float_t value, const Json::string_t&) { return Value(value); }
  bool string(Json::string_t& value) { return Value(std::move(value)); }
  bool binary(Json::binary_t& value) { return Value(Json::binary(std::move(value))); }
  bool start_object(std::size_t) { return Open(Json::object(), false); }
  bool key(Json::string_t& key) {
    if (build_) scopes_.back().key = std::move(key);
    return true;
  }
  bool end_object() { return Close(); }
  bool start_array(std::size_t) { return Open(Json::array(), true); }
  bool end_array() { return Close(); }
  bool parse_error(std::size_t, const std::string&, const Json::exception& e) {
    error_ = ParseErrorMessage(e);
    return false;
  }

  const std::string& error() const { return error_; }
  Json& root() { return root_; }

 private:
  struct Scope {
    Json* container = nullptr;  // Null when not building.
    bool is_array = false;
    std::string label;      // Where the container sits in its parent: "key" or "[3]".
    std::string key;        // Objects: the key of the value that comes next.
    size_t next_index = 0;  // Arrays: index of the next element.
    std::unordered_map<std::string, size_t> keys;  // Objects: key -> position.
  };

  bool Value(Json value) {
    if (build_) Place(std::move(value));
    return true;
  }

  bool Open(Json container, bool is_array) {
    if (static_cast<int>(scopes_.size()) >= max_depth_) {
      error_ = absl::StrCat("JSON nested deeper than ", max_depth_, " levels");
      return false;
    }
    Scope scope;
    scope.is_array = is_array;
    if (build_) {
      scope.label = ChildLabel();
      scope.container = Place(std::move(container));
    }
    scopes_.push_back(std::move(scope));
    return true;
  }

  bool Close() {
    scopes_.pop_back();
    return true;
  }

  // The label of the value about to be placed in the innermost container.
  std::string ChildLabel() const {
    if (scopes_.empty()) return "";
    const Scope& scope = scopes_.back();
    return scope.is_array ? absl::StrCat("[", scope.next_index, "]") : scope.key;
  }

  // The JSON path of the value about to be placed: "frames[2].image".
  std::string ChildPath() const {
    std::string path;
    auto append = [&path](const std::string& label) {
      if (label.empty()) return;
      if (!path.empty() && label[0] != '[') path.push_back('.');
      path += label;
    };
    for (const Scope& scope : scopes_) append(scope.label);
    append(ChildLabel());
    return path;
  }

  // Puts `value` where the innermost open container takes its next value
  // (the root when none is open); returns where it now lives.
  Json* Place(Json value) {
    if (scopes_.empty()) {
      root_ = std::move(value);
      return &root_;
    }
    Scope& scope = scopes_.back();
    if (scope.is_array) {
      Json::array_t& array = *scope.container->get_ptr<Json::array_t*>();
      array.push_back(std::move(value));
      ++scope.next_index;
      return &array.back();
    }
    Json::object_t& object = *scope.container->get_ptr<Json::object_t*>();
    const auto [known, inserted] = scope.keys.try_emplace(scope.key, object.size());
    if (!inserted) {
      if (duplicate_keys_ != nullptr) duplicate_keys_->push_back(ChildPath());
      Json& slot = (object.begin() + static_cast<std::ptrdiff_t>(known->second))->second;
      slot = std::move(value);
      return &slot;
    }
    object.emplace_back(scope.key, std::move(value));  // ordered_map is a vector of pairs.
    return &object.back().second;
  }

  const int max_depth_;
  const bool build_;
  std::vector<std::string>* duplicate_keys_;
  std::vector<Scope> scopes_;
  Json root_;
  std::string error_;
};

absl::Status CheckSize(std::string_view text, const JsonLimits& limits) {
  if (static_cast<int64_t>(text.size()) <= limits.max_bytes) return absl::OkStatus();
  return absl::InvalidArgumentError(absl::StrCat(
      "JSON of ", text.size(), " bytes exceeds the limit of ", limits.max_bytes, " bytes"));
}

// Runs `sax` over `text`; INVALID_ARGUMENT with its error when it stopped.
absl::Status RunSax(std::string_view text, BoundedSax& sax) {
  bool ok = false;
  try {
    ok = Json::sax_parse(text.begin(), text.end(), &sax);
  } catch (const std::exception& e) {
    return absl::InvalidArgumentError(ParseErrorMessage(e));
  }
  if (ok) return absl::OkStatus();
  return absl::InvalidArgumentError(sax.error().empty() ? "malformed JSON" : sax.error());
}

}  // namespace

absl::StatusOr<nlohmann::ordered_json> ParseBoundedJson(std::string_view text,
                                                        const JsonLimits& limits,
                                                        std::vector<std::string>* duplicate_keys) {
  if (absl::Status size = CheckSize(text, limits); !size.ok()) return size;
  BoundedSax sax(limits.max_depth, /*build=*/true, duplicate_keys);
  if (absl::Status parsed = RunSax(text, sax); !parsed.ok()) return parsed;
  return std::move(sax.root());
}

absl::Status CheckBoundedJson(std::string_view text, const JsonLimits& limits) {
  if (absl::Status size = CheckSize(text, limits); !size.ok()) return size;
  BoundedSax sax(limits.max_depth, /*build=*/false, nullptr);
  return RunSax(text, sax);
}

absl::Status ParseBoundedProtoJson(std::string_view text, google::protobuf::Message* message,
                                   const JsonLimits& limits, bool ignore_unknown_fields) {
  if (absl::Status bounded = CheckBoundedJson(text, limits); !bounded.ok()) return bounded;
  google::protobuf::util::JsonParseOptions options;
  options.ignore_unknown_fields = ignore_unknown_fields;
  try {
    const auto status =
        google::protobuf::util::JsonStringToMessage(std::string(text), message, options);
    if (!status.ok()) return absl::InvalidArgumentError(std::string(status.message()));
  } catch (const std::exception& e) {
    return absl::InvalidArgumentError(e.what());
  }
  return absl::OkStatus();
}

}  // namespace pf
