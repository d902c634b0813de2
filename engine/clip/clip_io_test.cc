// Tests of manifest parsing (strict, path-named problems) and writing
// (round trip, the manifest's spelling).
#include "engine/clip/clip_io.h"

#include <google/protobuf/util/json_util.h>

#include <cmath>
#include <string>
#include <vector>

#include "common/file_util.h"
#include "engine/clip/clip_test_util.h"
#include "gtest/gtest.h"
#include "pointforward/v1/clip.pb.h"
#include "tests/test_util.h"

namespace pf {
namespace {

using pointforward::v1::Clip;
using pointforward::v1::Frame;

// Parses `json` and returns its problems as "field: message" lines.
std::vector<std::string> Problems(const std::string& json) {
  std::vector<ClipProblem> problems;
  const absl::StatusOr<LoadedClip> loaded = ParseClip(json, "/clips/a", &problems);
  EXPECT_EQ(loaded.ok(), problems.empty());
  std::vector<std::string> lines;
  for (const ClipProblem& p : problems) lines.push_back(p.ToString());
  return lines;
}

TEST(ClipIo, ParsesProto3JsonMapping) {
  const std::string json = R"({
    "name": "segment-1",
    "cameras": [{"id": "front", "width": 640, "height": 480,
                 "intrinsics": {"fx": 500, "fy": 500.5, "cx": 320, "cy": 240},
                 "distortion": {"model": "OPENCV", "k1": -0.25}}],
    "frames": [
      {"camera": "front", "timestampUs": 1700000000000000, "image": "a.png",
       "worldFromCamera": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1], "role": "TARGET"},
      {"camera": "front", "timestamp_us": "100", "image": "b.png", "role": 1, "depth": null}
    ],
    "lidar": [{"timestampUs": 5, "points": "l.bin", "worldFromSensor": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]}],
    "instances": [{"id": "car", "category": "car",
                   "boxes": [{"timestampUs": 1e5, "center": [1, 2, 3], "size": [4, 2, 1.5],
                              "rotation": [1, 0, 0, 0]}]}]
  })";
  std::vector<ClipProblem> problems;
  const absl::StatusOr<LoadedClip> loaded = ParseClip(json, "/clips/a/", &problems);
  ASSERT_TRUE(loaded.ok()) << loaded.status();
  EXPECT_TRUE(problems.empty());
  EXPECT_EQ(loaded->dir, "/clips/a");
  const Clip& clip = loaded->clip;
  EXPECT_EQ(clip.name(), "segment-1");
  ASSERT_EQ(clip.cameras_size(), 1);
  EXPECT_EQ(clip.cameras(0).width(), 640);
  EXPECT_DOUBLE_EQ(clip.cameras(0).intrinsics().fy(), 500.5);
  EXPECT_EQ(clip.cameras(0).distortion().model(), pointforward::v1::Distortion::OPENCV);
  EXPECT_DOUBLE_EQ(clip.cameras(0).distortion().k1(), -0.25);
  ASSERT_EQ(clip.frames_size(), 2);
  EXPECT_EQ(clip.frames(0).timestamp_us(), 1700000000000000);
  EXPECT_EQ(clip.frames(0).world_from_camera_size(), 16);
  EXPECT_EQ(clip.frames(0).role(), Frame::TARGET);
  EXPECT_EQ(clip.frames(1).timestamp_us(), 100);     // Snake case, int64 as string.
  EXPECT_EQ(clip.frames(1).role(), Frame::CONTEXT);  // Enum by number.
  EXPECT_TRUE(clip.frames(1).depth().empty());       // null = default.
  EXPECT_EQ(clip.lidar(0).points(), "l.bin");
  EXPECT_EQ(clip.instances(0).boxes(0).timestamp_us(), 100000);  // Integral float.
  EXPECT_DOUBLE_EQ(clip.instances(0).boxes(0).size(2), 1.5);
}

TEST(ClipIo, NonFiniteNumbersAsStrings) {
  std::vector<ClipProblem> problems;
  const absl::StatusOr<LoadedClip> loaded = ParseClip(
      R"({"instances": [{"boxes": [{"center": ["NaN", "Infinity", "-Infinity"], "size": ["2.5"]}]}]})",
      "", &problems);
  ASSERT_TRUE(loaded.ok()) << loaded.status();
  const auto& box = loaded->clip.instances(0).boxes(0);
  EXPECT_TRUE(std::isnan(box.center(0)));
  EXPECT_EQ(box.center(1), INFINITY);
  EXPECT_EQ(box.center(2), -INFINITY);
  EXPECT_EQ(box.size(0), 2.5);
}

TEST(ClipIo, MalformedJsonGivesLineAndColumn) {
  const std::vector<std::string> problems =
      Problems("{\n  \"name\": \"x\",\n  \"cameras\": [,]\n}");
  ASSERT_EQ(problems.size(), 1u);
  EXPECT_NE(problems[0].find("malformed JSON"), std::string::npos) << problems[0];
  EXPECT_NE(problems[0].find("line 3, column 15"), std::string::npos) << problems[0];
}

TEST(ClipIo, TruncatedJson) {
  const std::vector<std::string> problems = Problems(R"({"cameras": [{"id": "a")");
  ASSERT_EQ(problems.size(), 1u);
  EXPECT_NE(problems[0].find("malformed JSON"), std::string::npos) << problems[0];
}

TEST(ClipIo, DeeplyNestedJsonIsOneProblemNotACrash) {
  // 100,000 levels in a string field: the parse and the "expected a string,
  // got ..." message once recursed through every level.
  const std::string deep =
      "{\"name\": " + std::string(100000, '[') + std::string(100000, ']') + "}";
  EXPECT_EQ(Problems(deep), std::vector<std::string>{"JSON nested deeper than 64 levels"});
  // Shallow enough: the field's problem, without printing the value.
  EXPECT_EQ(Problems(R"({"name": [[[1, 2]]]})"),
            std::vector<std::string>{"name: expected a string, got array"});
}

TEST(ClipIo, TopLevelMustBeObject) {
  EXPECT_EQ(Problems("[1, 2]"),
            std::vector<std::string>{"expected a JSON object at the top level, got array"});
}

TEST(ClipIo, UnknownFieldsNamedWithSuggestion) {
  const std::vector<std::string> problems = Problems(R"({
    "frames": [{}, {}, {"camera": "a", "imag": "x.png"}],
    "cameras": [{"id": "a", "intrinsics": {"fx": 1, "focal": 2}}],
    "extra": 1
  })");
  EXPECT_EQ(problems, (std::vector<std::string>{
                          "frames[2].imag: unknown field (did you mean 'image'?)",
                          "cameras[0].intrinsics.focal: unknown field",
                          "extra: unknown field",
                      }));
}

TEST(ClipIo, WrongTypesNamed) {
  const std::vector<std::string> problems = Problems(R"({
    "name": 3,
    "cameras": [{"id": "a", "width": "wide", "height": 2.5, "intrinsics": [1, 2]}],
    "frames": {"camera": "a"},
    "lidar": [{"worldFromSensor": [1, "x", null]}],
    "instances": [7]
  })");
  EXPECT_EQ(problems, (std::vector<std::string>{
                          "name: expected a string, got number 3",
                          "cameras[0].width: expected an integer, got string \"wide\"",
                          "cameras[0].height: expected an integer, got number 2.5",
                          "cameras[0].intrinsics: expected an object, got array",
                          "frames: expected an array, got object",
                          "lidar[0].worldFromSensor[1]: expected a number, got string \"x\"",
                          "lidar[0].worldFromSensor[2]: null is not allowed inside an array",
                          "instances[0]: expected an object, got number 7",
                      }));
}

TEST(ClipIo, IntegerOutOfRange) {
  EXPECT_EQ(
      Problems(R"({"cameras": [{"width": 3000000000}]})"),
      std::vector<std::string>{"cameras[0].width: integer 3000000000 is out of range for int32"});
  EXPECT_EQ(
      Problems(R"({"frames": [{"timestampUs": 1e30}]})"),
      std::vector<std::string>{"frames[0].timestampUs: integer 1e+30 is out of range for int64"});
}

TEST(ClipIo, UnknownEnumNamesListed) {
  EXPECT_EQ(
      Problems(R"({"frames": [{"role": "CONTXT"}], "cameras": [{"distortion": {"model": 9}}]})"),
      (std::vector<std::string>{
          "frames[0].role: unknown Role value \"CONTXT\" (expected one of "
          "ROLE_UNSPECIFIED, CONTEXT, TARGET)",
          "cameras[0].distortion.model: unknown Model value 9 (expected one of "
          "MODEL_UNSPECIFIED, NONE, OPENCV, FISHEYE, FTHETA)",
      }));
}

TEST(ClipIo, FieldGivenTwiceUnderBothNames) {
  EXPECT_EQ(Problems(R"({"frames": [{"timestampUs": 1, "timestamp_us": 2}]})"),
            std::vector<std::string>{"frames[0].timestamp_us: field 'timestampUs' given twice"});
}

TEST(ClipIo, DuplicateKeysNamed) {
  EXPECT_EQ(Problems(R"({"frames": [{"image": "a.png"}, {"image": "a.png", "image": "b.png"}],
                         "instances": [{"boxes": [{}, [], {"size": [1, 1, 1], "size": []}]}]})"),
            (std::vector<std::string>{
                "frames[1].image: key given twice in one object",
                "instances[0].boxes[2].size: key given twice in one object",
                "instances[0].boxes[1]: expected an object, got array",
            }));
}

TEST(ClipIo, LoadClipNamesMissingFile) {
  const std::string dir = testing::MakeTempDir("clip_io_missing");
  std::vector<ClipProblem> problems;
  const absl::StatusOr<LoadedClip> loaded = LoadClip(dir + "/nope.json", &problems);
  EXPECT_EQ(loaded.status().code(), absl::StatusCode::kNotFound);
  ASSERT_EQ(problems.size(), 1u);
  EXPECT_NE(problems[0].message.find("nope.json: file not found"), std::string::npos);
}

TEST(ClipIo, LoadClipStatusListsEveryProblem) {
  const std::string dir = testing::MakeTempDir("clip_io_status");
  ASSERT_TRUE(WriteFileAtomic(dir + "/clip.json", R"({"a": 1, "b": 2})").ok());
  const absl::StatusOr<LoadedClip> loaded = LoadClip(dir + "/clip.json");
  EXPECT_EQ(loaded.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(std::string(loaded.status().message()),
            dir + "/clip.json: a: unknown field\nb: unknown field");
}

TEST(ClipIo, SaveAndLoadRoundTrip) {
  const std::string dir = testing::MakeTempDir("clip_io_roundtrip");
  Clip clip = testing::MakeTestClip(dir);
  clip.mutable_frames(0)->set_timestamp_us(1700000000123456);
  clip.mutable_instances(0)->mutable_boxes(0)->set_center(0, 0.1);  // Not exact in binary.
  clip.mutable_instances(0)->mutable_boxes(0)->set_center(1, NAN);
  ASSERT_TRUE(SaveClip(clip, dir + "/out/clip.json").ok());

  const absl::StatusOr<LoadedClip> loaded = LoadClip(dir + "/out/clip.json");
  ASSERT_TRUE(loaded.ok()) << loaded.status();
  EXPECT_EQ(loaded->dir, dir + "/out");
  // NaN != NaN, so compare it apart and then the rest byte for byte.
  EXPECT_TRUE(std::isnan(loaded->clip.instances(0).boxes(0).center(1)));
  Clip expected = clip, actual = loaded->clip;
  expected.mutable_instances(0)->mutable_boxes(0)->set_center(1, 0);
  actual.mutable_instances(0)->mutable_boxes(0)->set_center(1, 0);
  EXPECT_EQ(actual.SerializeAsString(), expected.SerializeAsString());
}

// Clips written by protobuf's own JSON printer (int64 as strings, snake or
// camel case) read back unchanged.
TEST(ClipIo, ReadsProtobufJsonPrinterOutput) {
  const std::string dir = testing::MakeTempDir("clip_io_protobuf");
  Clip clip = testing::MakeTestClip(dir);
  clip.mutable_frames(2)->set_timestamp_us(1700000000123456);
  for (const bool snake_case : {false, true}) {
    google::protobuf::util::JsonPrintOptions options;
    options.add_whitespace = true;
    options.preserve_proto_field_names = snake_case;
    std::string json;
    ASSERT_TRUE(google::protobuf::util::MessageToJsonString(clip, &json, options).ok());
    ASSERT_NE(json.find("\"1700000000123456\""), std::string::npos);  // int64 as a string.
    const absl::StatusOr<LoadedClip> loaded = ParseClip(json, dir);
    ASSERT_TRUE(loaded.ok()) << loaded.status();
    EXPECT_EQ(loaded->clip.SerializeAsString(), clip.SerializeAsString());
  }
}

TEST(ClipIo, ClipToJsonUsesManifestSpelling) {
  Clip clip;
  Frame* frame = clip.add_frames();
  frame->set_camera("front");
  frame->set_timestamp_us(1700000000123456);
  frame->set_role(Frame::TARGET);
  for (int i = 0; i < 16; ++i) frame->add_world_from_camera(i % 5 == 0 ? 1 : 0);
  EXPECT_EQ(ClipToJson(clip),
            "{\n"
            "  \"frames\": [\n"
            "    {\n"
            "      \"camera\": \"front\",\n"
            "      \"timestampUs\": 1700000000123456,\n"
            "      \"worldFromCamera\": [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, "
            "0.0, 0.0, 0.0, 0.0, 1.0],\n"
            "      \"role\": \"TARGET\"\n"
            "    }\n"
            "  ]\n"
            "}\n");
}

}  // namespace
}  // namespace pf

namespace pf {
namespace {

TEST(ReferencedFilesTest, ListsMasksImagesDepthsAndSweepsOnceEachInManifestOrder) {
  pointforward::v1::Clip clip;
  clip.add_cameras()->set_ego_mask("masks/front.png");
  clip.add_cameras();  // No mask: not listed.
  auto* f0 = clip.add_frames();
  f0->set_image("images/a.png");
  f0->set_depth("depth/a.exr");
  auto* f1 = clip.add_frames();
  f1->set_image("images/b.png");
  f1->set_depth("depth/a.exr");  // Shared: listed at its first field only.
  clip.add_lidar()->set_points("lidar/0.bin");
  clip.add_lidar();  // No path: not listed.

  const std::vector<ClipFileRef> refs = ReferencedFiles(clip);
  ASSERT_EQ(refs.size(), 5u);
  EXPECT_EQ(refs[0].field, "cameras[0].egoMask");
  EXPECT_EQ(refs[0].path, "masks/front.png");
  EXPECT_EQ(refs[1].field, "frames[0].image");
  EXPECT_EQ(refs[1].path, "images/a.png");
  EXPECT_EQ(refs[2].field, "frames[0].depth");
  EXPECT_EQ(refs[2].path, "depth/a.exr");
  EXPECT_EQ(refs[3].field, "frames[1].image");
  EXPECT_EQ(refs[3].path, "images/b.png");
  EXPECT_EQ(refs[4].field, "lidar[0].points");
  EXPECT_EQ(refs[4].path, "lidar/0.bin");
}

}  // namespace
}  // namespace pf
