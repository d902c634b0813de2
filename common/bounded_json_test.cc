// Tests for the bounded JSON parser: nesting and size limits, duplicate keys
// with their paths, the same tree as nlohmann's own parser, and protobuf
// JSON behind the same checks.
#include "common/bounded_json.h"

#include <google/protobuf/struct.pb.h>
#include <gtest/gtest.h>

#include <iterator>
#include <string>

namespace pf {
namespace {

using Json = nlohmann::ordered_json;

// `{"name":[[...[]...]]}` with `depth` levels in all (the object counts).
std::string NestedArrays(int depth) {
  return "{\"name\":" + std::string(depth - 1, '[') + std::string(depth - 1, ']') + "}";
}

TEST(BoundedJson, DeepNestingIsRefusedNotRecursedInto) {
  // 100,000 levels: a recursive parser or a recursive walk of the tree
  // overflows the stack long before the end.
  const absl::StatusOr<Json> deep = ParseBoundedJson(NestedArrays(100000));
  ASSERT_FALSE(deep.ok());
  EXPECT_EQ(deep.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(deep.status().message(), "JSON nested deeper than 64 levels");
  EXPECT_EQ(CheckBoundedJson(NestedArrays(100000)).message(), "JSON nested deeper than 64 levels");
}

TEST(BoundedJson, TheDepthLimitIsExact) {
  const absl::StatusOr<Json> at_limit = ParseBoundedJson(NestedArrays(64));
  ASSERT_TRUE(at_limit.ok()) << at_limit.status();
  const Json* inner = &(*at_limit)["name"];
  int levels = 1;
  while (inner->is_array() && !inner->empty()) {
    inner = &(*inner)[0];
    ++levels;
  }
  EXPECT_EQ(levels, 63);
  EXPECT_FALSE(ParseBoundedJson(NestedArrays(65)).ok());
  EXPECT_TRUE(ParseBoundedJson(NestedArrays(3), {.max_bytes = 100, .max_depth = 3}).ok());
  EXPECT_FALSE(ParseBoundedJson(NestedArrays(4), {.max_bytes = 100, .max_depth = 3}).ok());
}

TEST(BoundedJson, TextOverTheSizeLimitIsRefusedBeforeParsing) {
  const std::string text = "[1, 2, 3]";
  EXPECT_TRUE(ParseBoundedJson(text, {.max_bytes = 9}).ok());
  const absl::StatusOr<Json> big = ParseBoundedJson(text, {.max_bytes = 8});
  EXPECT_EQ(big.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(big.status().message(), "JSON of 9 bytes exceeds the limit of 8 bytes");
  EXPECT_EQ(CheckBoundedJson(text, {.max_bytes = 8}).message(),
            "JSON of 9 bytes exceeds the limit of 8 bytes");
}

TEST(BoundedJson, BuildsTheSameTreeAsNlohmann) {
  const std::string text = R"({"b": 1, "a": [true, null, -3, 18446744073709551615, 2.5e-3,
    "x\u00e9", {"z": {}, "y": []}], "c": {"k": "v"}})";
  const absl::StatusOr<Json> bounded = ParseBoundedJson(text);
  ASSERT_TRUE(bounded.ok()) << bounded.status();
  const Json reference = Json::parse(text);
  EXPECT_EQ(*bounded, reference);
  EXPECT_EQ(bounded->dump(), reference.dump());  // Key order kept too.
  EXPECT_TRUE((*bounded)["a"][3].is_number_unsigned());
}

TEST(BoundedJson, DuplicateKeysAreReportedWithTheirPathAndTheLaterValueWins) {
  std::vector<std::string> duplicates;
  const absl::StatusOr<Json> parsed = ParseBoundedJson(
      R"({"frames": [{"image": "a"}, {"image": "b", "image": "c"}], "x": 1, "x": 2})", {},
      &duplicates);
  ASSERT_TRUE(parsed.ok()) << parsed.status();
  EXPECT_EQ(duplicates, (std::vector<std::string>{"frames[1].image", "x"}));
  EXPECT_EQ(parsed->dump(), R"({"frames":[{"image":"a"},{"image":"c"}],"x":2})");
}

TEST(BoundedJson, MalformedJsonNamesLineAndColumn) {
  const absl::StatusOr<Json> bad = ParseBoundedJson("{\n  \"a\": [1, 2,\n}");
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(std::string(bad.status().message()).rfind("malformed JSON: parse error at line 3", 0),
            0u)
      << bad.status();
  EXPECT_FALSE(ParseBoundedJson("").ok());
  EXPECT_FALSE(ParseBoundedJson("[1] [2]").ok());
}

TEST(BoundedJson, ManyElementsAndManyKeysParseInOnePass) {
  // 20,000 frames and an object of 20,000 distinct keys: a parse that
  // searched the siblings of every value (nlohmann's callback parser, an
  // ordered_json object's linear find) was quadratic in these.
  std::string frames = "{\"frames\": [";
  for (int i = 0; i < 20000; ++i) {
    if (i > 0) frames += ",";
    frames += "{\"image\": \"i.png\", \"timestampUs\": " + std::to_string(i) + "}";
  }
  frames += "]}";
  const absl::StatusOr<Json> parsed = ParseBoundedJson(frames);
  ASSERT_TRUE(parsed.ok()) << parsed.status();
  EXPECT_EQ((*parsed)["frames"].size(), 20000u);
  EXPECT_EQ((*parsed)["frames"][19999]["timestampUs"], 19999);

  std::string keys = "{";
  for (int i = 0; i < 20000; ++i) {
    if (i > 0) keys += ",";
    keys += "\"k" + std::to_string(i) + "\": " + std::to_string(i);
  }
  keys += "}";
  const absl::StatusOr<Json> object = ParseBoundedJson(keys);
  ASSERT_TRUE(object.ok()) << object.status();
  EXPECT_EQ(object->size(), 20000u);
  EXPECT_EQ(object->begin().key(), "k0");
  EXPECT_EQ(std::prev(object->end()).key(), "k19999");
}

TEST(BoundedProtoJson, ProtobufJsonIsCheckedAgainstTheSameLimits) {
  google::protobuf::Value value;
  const absl::Status deep =
      ParseBoundedProtoJson(std::string(100000, '[') + std::string(100000, ']'), &value);
  EXPECT_EQ(deep.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(deep.message(), "JSON nested deeper than 64 levels");

  google::protobuf::Struct object;
  ASSERT_TRUE(ParseBoundedProtoJson(R"({"a": [1, "x"], "b": {"c": true}})", &object).ok());
  EXPECT_EQ(object.fields().at("a").list_value().values(1).string_value(), "x");
  EXPECT_TRUE(object.fields().at("b").struct_value().fields().at("c").bool_value());
  EXPECT_EQ(ParseBoundedProtoJson("{}", &object, {.max_bytes = 1}).code(),
            absl::StatusCode::kInvalidArgument);
  // A message protobuf refuses: its message comes back as INVALID_ARGUMENT.
  google::protobuf::ListValue list;
  EXPECT_EQ(ParseBoundedProtoJson(R"({"values": 3})", &list).code(),
            absl::StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace pf
