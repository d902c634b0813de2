// Tests of synth.json reading and writing.
#include "engine/synth/synth_params.h"

#include <gtest/gtest.h>

namespace pf {
namespace {

std::string Message(const absl::Status& status) { return std::string(status.message()); }

TEST(SynthParams, RoundTrips) {
  SynthOptions options;
  options.seed = 123456789012;
  options.num_cameras = 5;
  options.num_frames = 7;
  options.width = 320;
  options.height = 240;
  options.antialias = 3;
  const auto back = SynthParamsFromJson(SynthParamsToJson(options), "synth.json");
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(back->seed, options.seed);
  EXPECT_EQ(back->num_cameras, 5);
  EXPECT_EQ(back->num_frames, 7);
  EXPECT_EQ(back->width, 320);
  EXPECT_EQ(back->height, 240);
  EXPECT_EQ(back->antialias, 3);
  EXPECT_EQ(back->lens, SynthLens::kPinhole);
  // Pinhole clips keep their synth.json as it was; f-theta ones say so.
  EXPECT_EQ(SynthParamsToJson(options).find("lens"), std::string::npos);
  options.lens = SynthLens::kFTheta;
  const auto ftheta = SynthParamsFromJson(SynthParamsToJson(options), "synth.json");
  ASSERT_TRUE(ftheta.ok()) << ftheta.status();
  EXPECT_EQ(ftheta->lens, SynthLens::kFTheta);
}

TEST(SynthParams, RejectsBadFilesNamingTheField) {
  const std::string good =
      R"({"generator": "pf synth", "version": 1, "seed": 1, "cameras": 3, "frames": 20,
          "width": 768, "height": 576, "antialias": 2)";
  ASSERT_TRUE(SynthParamsFromJson(good + "}", "s.json").ok());

  auto status = SynthParamsFromJson("{not json", "s.json").status();
  EXPECT_TRUE(absl::IsInvalidArgument(status));
  EXPECT_NE(Message(status).find("s.json: malformed JSON"), std::string::npos) << status;

  status = SynthParamsFromJson(good + R"(, "colour": 1})", "s.json").status();
  EXPECT_NE(Message(status).find("colour: unknown field"), std::string::npos) << status;

  status = SynthParamsFromJson(
               R"({"generator": "pf synth", "version": 1, "seed": 1, "cameras": 3})", "s.json")
               .status();
  EXPECT_NE(Message(status).find("frames: missing"), std::string::npos) << status;

  std::string text = good + "}";
  text.replace(text.find("\"width\": 768"), 12, "\"width\": 7.5");
  status = SynthParamsFromJson(text, "s.json").status();
  EXPECT_NE(Message(status).find("width: not an integer"), std::string::npos) << status;

  text = good + "}";
  text.replace(text.find("\"height\": 576"), 13, "\"height\": 5");
  status = SynthParamsFromJson(text, "s.json").status();
  EXPECT_NE(Message(status).find("s.json: height: must be in"), std::string::npos) << status;

  status = SynthParamsFromJson(good + R"(, "lens": "fisheye"})", "s.json").status();
  EXPECT_NE(Message(status).find(R"(s.json: lens: must be "pinhole" or "ftheta", got "fisheye")"),
            std::string::npos)
      << status;

  text = good + "}";
  text.replace(text.find("\"version\": 1"), 12, "\"version\": 9");
  status = SynthParamsFromJson(text, "s.json").status();
  EXPECT_TRUE(absl::IsFailedPrecondition(status)) << status;
  EXPECT_NE(Message(status).find("version"), std::string::npos) << status;
}

TEST(SynthParams, MissingFileIsNotFound) {
  const auto status = ReadSynthParams("/nonexistent/synth.json").status();
  EXPECT_TRUE(absl::IsNotFound(status)) << status;
}

}  // namespace
}  // namespace pf
