// Tests of ValidateClip: a valid clip passes with the right summary, and each
// rule, broken alone in an otherwise valid clip, yields a problem naming the
// field and what is wrong.
#include "engine/clip/clip_validator.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "common/file_util.h"
#include "engine/clip/clip_io.h"
#include "engine/clip/clip_test_util.h"
#include "engine/image/image_io.h"
#include "gtest/gtest.h"
#include "pointforward/v1/clip.pb.h"
#include "tests/test_util.h"

namespace pf {
namespace {

namespace fs = std::filesystem;
using pointforward::v1::Camera;
using pointforward::v1::Clip;
using pointforward::v1::Distortion;
using pointforward::v1::Frame;
using testing::MakeTempDir;
using testing::MakeTestClip;

std::string Dump(const ClipReport& report) {
  std::string text = "problems:\n";
  for (const ClipProblem& p : report.problems) text += "  " + p.ToString() + "\n";
  return text;
}

// Succeeds when `report` has a problem at exactly `field` whose message
// contains `message`.
::testing::AssertionResult HasProblem(const ClipReport& report, const std::string& field,
                                      const std::string& message) {
  for (const ClipProblem& p : report.problems) {
    if (p.field == field && p.message.find(message) != std::string::npos) {
      return ::testing::AssertionSuccess();
    }
  }
  return ::testing::AssertionFailure()
         << "no problem '" << field << ": ..." << message << "...'; " << Dump(report);
}

ClipReport Validate(const Clip& clip, const std::string& dir, ValidateOptions options = {}) {
  return ValidateClip(LoadedClip{clip, dir}, options);
}

TEST(ClipValidator, ValidClipPassesWithSummary) {
  const std::string dir = MakeTempDir("clip_valid");
  const Clip clip = MakeTestClip(dir);
  const ClipReport report = Validate(clip, dir);
  EXPECT_TRUE(report.ok()) << Dump(report);
  EXPECT_EQ(report.summary.cameras, 2);
  EXPECT_EQ(report.summary.frames, 6);
  EXPECT_EQ(report.summary.context_frames, 2);
  EXPECT_EQ(report.summary.target_frames, 4);
  EXPECT_EQ(report.summary.first_timestamp_us, 0);
  EXPECT_EQ(report.summary.last_timestamp_us, 200000);
  EXPECT_EQ(report.summary.instances, 1);
  EXPECT_EQ(report.summary.boxes, 3);
  EXPECT_EQ(report.summary.lidar_sweeps, 2);
  EXPECT_EQ(report.summary.ToString(),
            "2 cameras, 6 frames (2 CONTEXT, 4 TARGET), timestamps 0..200000 us, 1 instance, "
            "2 LiDAR sweeps");
}

TEST(ClipValidator, ValidClipFromFilePasses) {
  const std::string dir = MakeTempDir("clip_valid_file");
  const std::string path = testing::WriteTestClip(dir, MakeTestClip(dir));
  const ClipReport report = ValidateClipFile(path, {});
  EXPECT_TRUE(report.ok()) << Dump(report);
  EXPECT_EQ(report.summary.frames, 6);
}

TEST(ClipValidator, EgoMaskOfTheCamerasSizePasses) {
  const std::string dir = MakeTempDir("clip_ego");
  Clip clip = MakeTestClip(dir);
  ImageF hood(testing::kTestWidth, testing::kTestHeight, 1);
  for (int x = 0; x < testing::kTestWidth; ++x) hood.at(x, testing::kTestHeight - 1, 0) = 1.f;
  ASSERT_TRUE(WritePng(dir + "/hood.png", hood).ok());
  clip.mutable_cameras(0)->set_ego_mask("hood.png");
  const ClipReport report = Validate(clip, dir);
  EXPECT_TRUE(report.ok()) << Dump(report);
  const std::vector<uint8_t> mask = EgoMaskFromImage(*ReadImage(dir + "/hood.png"));
  ASSERT_EQ(mask.size(), size_t(testing::kTestWidth * testing::kTestHeight));
  EXPECT_EQ(std::count(mask.begin(), mask.end(), 1), testing::kTestWidth);
  EXPECT_EQ(mask.back(), 1);
  EXPECT_EQ(mask.front(), 0);
}

// Camera 1 of the test clip as an f-theta lens: 30 px per radian at the
// centre, focal lengths left at 0.
void MakeFTheta(Clip* clip) {
  Camera* camera = clip->mutable_cameras(1);
  camera->mutable_intrinsics()->clear_fx();
  camera->mutable_intrinsics()->clear_fy();
  Distortion* d = camera->mutable_distortion();
  d->Clear();
  d->set_model(Distortion::FTHETA);
  for (double c : {0.0, 30.0, 0.0, -1.5}) d->add_ftheta_poly(c);
}

TEST(ClipValidator, FThetaCameraWithoutFocalLengthsPasses) {
  const std::string dir = MakeTempDir("clip_ftheta");
  Clip clip = MakeTestClip(dir);
  MakeFTheta(&clip);
  EXPECT_TRUE(Validate(clip, dir).ok()) << Dump(Validate(clip, dir));
  const std::string path = testing::WriteTestClip(dir, clip);
  const ClipReport from_file = ValidateClipFile(path, {});
  EXPECT_TRUE(from_file.ok()) << Dump(from_file);
  // The JSON names the polynomial as the manifest documents it.
  EXPECT_NE(ReadFileToString(path)->find("\"fthetaPoly\""), std::string::npos);
}

TEST(ClipValidator, TimestampRangeIgnoresFrameOrder) {
  const std::string dir = MakeTempDir("clip_order");
  Clip clip = MakeTestClip(dir);
  clip.mutable_frames(4)->set_timestamp_us(-50000);  // front, was 200000.
  clip.mutable_frames(0)->set_timestamp_us(900000);  // front, was 0.
  const ClipReport report = Validate(clip, dir);
  EXPECT_TRUE(report.ok()) << Dump(report);
  EXPECT_EQ(report.summary.first_timestamp_us, -50000);
  EXPECT_EQ(report.summary.last_timestamp_us, 900000);
}

TEST(ClipValidator, Depth16BitPngIsAccepted) {
  const std::string dir = MakeTempDir("clip_png16");
  Clip clip = MakeTestClip(dir);
  ImageF depth(testing::kTestWidth, testing::kTestHeight, 1);
  for (float& d : depth.pixels) d = 12.5f;
  ASSERT_TRUE(WriteDepthPng16(dir + "/depth/front_0.png", depth).ok());
  clip.mutable_frames(0)->set_depth("depth/front_0.png");
  const ClipReport report = Validate(clip, dir);
  EXPECT_TRUE(report.ok()) << Dump(report);
}

TEST(ClipValidator, OutsidePathsAllowedWhenAsked) {
  const std::string dir = MakeTempDir("clip_outside");
  const std::string other = MakeTempDir("clip_outside_files");
  Clip clip = MakeTestClip(dir);
  testing::WriteTestImage(other + "/far.png", testing::kTestWidth, testing::kTestHeight);
  clip.mutable_frames(0)->set_image(other + "/far.png");  // Absolute.
  const std::string relative = fs::relative(other + "/far.png", dir).string();
  clip.mutable_frames(1)->set_image(relative);  // "../clip_outside_files_X/far.png".
  ASSERT_EQ(relative.substr(0, 3), "../");

  const ClipReport strict = Validate(clip, dir);
  EXPECT_EQ(strict.problems.size(), 2u) << Dump(strict);
  EXPECT_TRUE(HasProblem(strict, "frames[0].image", "is absolute"));
  EXPECT_TRUE(HasProblem(strict, "frames[1].image", "escapes the clip directory"));

  ValidateOptions options;
  options.allow_outside_paths = true;
  const ClipReport relaxed = Validate(clip, dir, options);
  EXPECT_TRUE(relaxed.ok()) << Dump(relaxed);
}

TEST(ClipValidator, ReportsEveryProblemInManifestOrder) {
  const std::string dir = MakeTempDir("clip_many");
  Clip clip = MakeTestClip(dir);
  clip.mutable_instances(0)->mutable_boxes(0)->set_size(0, -1);
  clip.mutable_frames(3)->set_camera("rear");
  clip.mutable_cameras(1)->set_width(0);
  fs::remove(dir + "/images/front_2.png");
  const ClipReport report = Validate(clip, dir);
  ASSERT_EQ(report.problems.size(), 4u) << Dump(report);
  EXPECT_EQ(report.problems[0].field, "cameras[1].width");
  EXPECT_EQ(report.problems[1].field, "frames[3].camera");
  EXPECT_EQ(report.problems[2].field, "frames[4].image");
  EXPECT_EQ(report.problems[3].field, "instances[0].boxes[0].size[0]");
}

// What pf reconstruct and pf eval load: the clip when it is valid, else one
// error with pf validate's lines.
TEST(ClipValidator, LoadValidClipStopsWithEveryProblem) {
  const std::string dir = MakeTempDir("clip_load_valid");
  Clip clip = MakeTestClip(dir);
  const std::string path = testing::WriteTestClip(dir, clip);
  absl::StatusOr<LoadedClip> loaded = LoadValidClip(path, {});
  ASSERT_TRUE(loaded.ok()) << loaded.status();
  EXPECT_EQ(loaded->clip.frames_size(), 6);

  clip.mutable_frames(4)->clear_camera();  // A TARGET frame: reconstruction never reads it.
  testing::WriteTestClip(dir, clip);
  loaded = LoadValidClip(path, {});
  EXPECT_EQ(loaded.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(loaded.status().message(), "frames[4].camera: missing (the id of one of the cameras)");

  clip.mutable_cameras(1)->set_width(0);
  testing::WriteTestClip(dir, clip);
  loaded = LoadValidClip(path, {});
  EXPECT_EQ(loaded.status().code(), absl::StatusCode::kInvalidArgument);
  const std::string message(loaded.status().message());
  EXPECT_EQ(message.rfind(path + ": ", 0), 0u) << message;
  EXPECT_NE(message.find("problems (pf validate lists them):\n  cameras[1].width: "),
            std::string::npos)
      << message;
  EXPECT_NE(message.find("\n  frames[4].camera: missing"), std::string::npos) << message;

  EXPECT_EQ(LoadValidClip(dir + "/none.json", {}).status().code(), absl::StatusCode::kNotFound);
  EXPECT_EQ(LoadValidClip(dir, {}).status().message(), dir + ": is a directory, not a file");
}

TEST(ClipValidator, SkipsFilesWhenAsked) {
  const std::string dir = MakeTempDir("clip_nofiles");
  Clip clip = MakeTestClip(dir);
  fs::remove(dir + "/images/front_0.png");
  ValidateOptions options;
  options.check_files = false;
  EXPECT_TRUE(Validate(clip, dir, options).ok());
  EXPECT_FALSE(Validate(clip, dir).ok());
}

TEST(ClipValidator, ResolveClipPathJoinsAndRejects) {
  const LoadedClip loaded{Clip(), "/data/clips/a"};
  EXPECT_EQ(ResolveClipPath(loaded, "images/x.png", false).value(), "/data/clips/a/images/x.png");
  EXPECT_EQ(ResolveClipPath(loaded, "./images/../y.png", false).value(), "/data/clips/a/y.png");
  EXPECT_FALSE(ResolveClipPath(loaded, "../b/x.png", false).ok());
  EXPECT_FALSE(ResolveClipPath(loaded, "/etc/passwd", false).ok());
  EXPECT_EQ(ResolveClipPath(loaded, "../b/x.png", true).value(), "/data/clips/b/x.png");
  EXPECT_EQ(ResolveClipPath(loaded, "/etc/passwd", true).value(), "/etc/passwd");
}

// Keeps docs/MANIFEST.md honest: its example parses, passes the manifest
// checks and has the summary the page says.
TEST(ClipValidator, ManifestDocExampleIsValid) {
  const std::string doc_path = (fs::path(testing::SourceDir()) / "docs/MANIFEST.md").string();
  const absl::StatusOr<std::string> doc = ReadFileToString(doc_path);
  ASSERT_TRUE(doc.ok()) << doc.status();
  const size_t begin = doc->find("```json\n");
  ASSERT_NE(begin, std::string::npos) << "no ```json block in " << doc_path;
  const size_t end = doc->find("```", begin + 8);
  ASSERT_NE(end, std::string::npos);
  const absl::StatusOr<LoadedClip> loaded =
      ParseClip(doc->substr(begin + 8, end - begin - 8), "/clips/example");
  ASSERT_TRUE(loaded.ok()) << loaded.status();
  ValidateOptions options;
  options.check_files = false;  // The page shows no image files.
  const ClipReport report = ValidateClip(*loaded, options);
  EXPECT_TRUE(report.ok()) << Dump(report);
  const std::string line = "valid: " + report.summary.ToString();
  EXPECT_NE(doc->find(line), std::string::npos) << "the page should show '" << line << "'";
}

// One rule broken in the test clip (see clip_test_util.h for its layout:
// frames[2t] "front", frames[2t+1] "left" at t * 100000 us).
struct BrokenClip {
  std::string name;
  std::function<void(Clip* clip, const std::string& dir)> mutate;
  std::string field;    // The problem's field path.
  std::string message;  // A part of its message.
  int count = 1;        // Number of problems expected in all; -1 for any.
};

std::ostream& operator<<(std::ostream& os, const BrokenClip& c) { return os << c.name; }

class ClipValidatorRule : public ::testing::TestWithParam<BrokenClip> {};

TEST_P(ClipValidatorRule, NamesFieldAndProblem) {
  const BrokenClip& c = GetParam();
  const std::string dir = MakeTempDir("clip_rule");
  Clip clip = MakeTestClip(dir);
  c.mutate(&clip, dir);

  const ClipReport report = Validate(clip, dir);
  EXPECT_FALSE(report.ok());
  EXPECT_TRUE(HasProblem(report, c.field, c.message));
  if (c.count >= 0) EXPECT_EQ(report.problems.size(), size_t(c.count)) << Dump(report);

  // The same clip through its JSON file gives the same problems.
  const ClipReport from_file = ValidateClipFile(testing::WriteTestClip(dir, clip), {});
  ASSERT_EQ(from_file.problems.size(), report.problems.size()) << Dump(from_file);
  for (size_t i = 0; i < report.problems.size(); ++i) {
    EXPECT_EQ(from_file.problems[i].ToString(), report.problems[i].ToString());
  }
}

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

void Remove(const std::string& path) { ASSERT_TRUE(fs::remove(path)) << path; }

const BrokenClip kBrokenClips[] = {
    // Cameras.
    {"NoCameras", [](Clip* c, auto) { c->clear_cameras(); }, "cameras", "missing", -1},
    {"CameraIdMissing", [](Clip* c, auto) { c->mutable_cameras(1)->clear_id(); }, "cameras[1].id",
     "missing", -1},
    {"CameraWidthMissing", [](Clip* c, auto) { c->mutable_cameras(0)->clear_width(); },
     "cameras[0].width", "missing"},
    {"CameraHeightNegative", [](Clip* c, auto) { c->mutable_cameras(0)->set_height(-5); },
     "cameras[0].height", "must be positive, got -5"},
    {"IntrinsicsMissing", [](Clip* c, auto) { c->mutable_cameras(1)->clear_intrinsics(); },
     "cameras[1].intrinsics", "missing"},
    {"FocalLengthNegative",
     [](Clip* c, auto) { c->mutable_cameras(0)->mutable_intrinsics()->set_fx(-30); },
     "cameras[0].intrinsics.fx", "focal length must be positive, got -30"},
    {"FocalLengthZero",
     [](Clip* c, auto) { c->mutable_cameras(0)->mutable_intrinsics()->set_fy(0); },
     "cameras[0].intrinsics.fy", "focal length"},
    {"PrincipalPointNaN",
     [](Clip* c, auto) { c->mutable_cameras(0)->mutable_intrinsics()->set_cx(kNaN); },
     "cameras[0].intrinsics.cx", "not a finite number"},
    {"DistortionCoefficientInfinite",
     [](Clip* c, auto) { c->mutable_cameras(1)->mutable_distortion()->set_k2(kInf); },
     "cameras[1].distortion.k2", "not a finite number"},
    {"DistortionCoefficientsWithoutModel",
     [](Clip* c, auto) {
       c->mutable_cameras(1)->mutable_distortion()->set_model(Distortion::NONE);
     },
     "cameras[1].distortion.model", "coefficients are set but the model is NONE"},
    {"FThetaPolynomialOnAnotherModel",
     [](Clip* c, auto) { c->mutable_cameras(1)->mutable_distortion()->add_ftheta_poly(0); },
     "cameras[1].distortion.fthetaPoly", "only the FTHETA model uses the f-theta polynomials"},
    {"FThetaWithBrownConradyCoefficients",
     [](Clip* c, auto) {
       MakeFTheta(c);
       c->mutable_cameras(1)->mutable_distortion()->set_k1(-0.1);
     },
     "cameras[1].distortion.model", "the FTHETA model takes fthetaPoly"},
    {"FThetaWithoutPolynomial",
     [](Clip* c, auto) {
       MakeFTheta(c);
       c->mutable_cameras(1)->mutable_distortion()->clear_ftheta_poly();
     },
     "cameras[1].distortion.fthetaPoly", "missing: FTHETA needs fthetaPoly"},
    {"FThetaPolynomialOffTheAxis",
     [](Clip* c, auto) {
       MakeFTheta(c);
       c->mutable_cameras(1)->mutable_distortion()->set_ftheta_poly(0, 2.0);
     },
     "cameras[1].distortion.fthetaPoly[0]", "must be 0"},
    {"FThetaFocalLengthNotThePolynomials",
     [](Clip* c, auto) {
       MakeFTheta(c);
       c->mutable_cameras(1)->mutable_intrinsics()->set_fx(40);
     },
     "cameras[1].intrinsics.fx", "focal length is fthetaPoly[1] (30 px per radian)"},
    {"DuplicateCameraId", [](Clip* c, auto) { c->mutable_cameras(1)->set_id("front"); },
     "cameras[1].id", "duplicate camera id 'front' (also cameras[0])", -1},
    {"EgoMaskFileMissing", [](Clip* c, auto) { c->mutable_cameras(0)->set_ego_mask("hood.png"); },
     "cameras[0].egoMask", "file not found"},
    {"EgoMaskSizeDiffers",
     [](Clip* c, const std::string& dir) {
       testing::WriteTestImage(dir + "/hood.png", 16, 12);
       c->mutable_cameras(0)->set_ego_mask("hood.png");
     },
     "cameras[0].egoMask", "mask is 16x12 but camera 'front' is 32x24"},
    {"EgoMaskEverywhere",
     [](Clip* c, const std::string& dir) {
       ImageF white(testing::kTestWidth, testing::kTestHeight, 1);
       for (float& v : white.pixels) v = 1.f;
       ASSERT_TRUE(WritePng(dir + "/hood.png", white).ok());
       c->mutable_cameras(1)->set_ego_mask("hood.png");
     },
     "cameras[1].egoMask", "every pixel is marked as the ego body"},

    // Frames.
    {"NoFrames", [](Clip* c, auto) { c->clear_frames(); }, "frames", "missing"},
    {"FrameCameraMissing", [](Clip* c, auto) { c->mutable_frames(1)->clear_camera(); },
     "frames[1].camera", "missing"},
    {"UnknownCameraId", [](Clip* c, auto) { c->mutable_frames(3)->set_camera("rear"); },
     "frames[3].camera", "unknown camera id 'rear' (known: front, left)"},
    {"DuplicateCameraTimestamp",
     [](Clip* c, auto) { c->mutable_frames(4)->set_timestamp_us(100000); }, "frames[4].timestampUs",
     "duplicate (camera 'front', timestampUs 100000): also frames[2]"},
    {"ImageMissingField", [](Clip* c, auto) { c->mutable_frames(2)->clear_image(); },
     "frames[2].image", "missing"},
    {"ImageFileMissing", [](Clip*, const std::string& dir) { Remove(dir + "/images/left_1.png"); },
     "frames[3].image", "file not found"},
    {"ImageUnreadable",
     [](Clip*, const std::string& dir) {
       ASSERT_TRUE(WriteFileAtomic(dir + "/images/left_1.png", "not a png").ok());
     },
     "frames[3].image", "not a readable image"},
    {"ImageTruncated",
     [](Clip*, const std::string& dir) {
       const std::string path = dir + "/images/left_1.png";
       const std::string bytes = ReadFileToString(path).value();
       ASSERT_TRUE(WriteFileAtomic(path, bytes.substr(0, bytes.size() / 2)).ok());
     },
     "frames[3].image", "", 1},
    {"ImageSizeDiffers",
     [](Clip*, const std::string& dir) {
       testing::WriteTestImage(dir + "/images/front_1.png", 16, 12);
     },
     "frames[2].image", "image is 16x12 but camera 'front' is 32x24"},
    {"PoseMissing", [](Clip* c, auto) { c->mutable_frames(0)->clear_world_from_camera(); },
     "frames[0].worldFromCamera", "missing (16 numbers"},
    {"PoseWrongLength",
     [](Clip* c, auto) { c->mutable_frames(0)->mutable_world_from_camera()->Truncate(12); },
     "frames[0].worldFromCamera", "expected 16 numbers (a row-major 4x4 matrix), got 12"},
    {"PoseNonFinite", [](Clip* c, auto) { c->mutable_frames(5)->set_world_from_camera(3, kInf); },
     "frames[5].worldFromCamera[3]", "not a finite number (inf)"},
    {"PoseTranslationAbsurd",
     [](Clip* c, auto) { c->mutable_frames(5)->set_world_from_camera(7, 1e308); },
     "frames[5].worldFromCamera[7]",
     "1e+308 m is beyond the 1e+07 m any world coordinate may have"},
    {"PoseNotRigid",
     [](Clip* c, auto) {
       // Scale the rotation by 0.9: det = 0.729.
       for (int r = 0; r < 3; ++r) {
         for (int k = 0; k < 3; ++k) {
           const int i = 4 * r + k;
           c->mutable_frames(4)->set_world_from_camera(i, 0.9 * c->frames(4).world_from_camera(i));
         }
       }
     },
     "frames[4].worldFromCamera", "not a rigid transform (det = 0.729"},
    {"PoseBadLastRow", [](Clip* c, auto) { c->mutable_frames(4)->set_world_from_camera(12, 1); },
     "frames[4].worldFromCamera", "not a rigid transform (det = 1,"},
    {"RollingShutterWithoutReadout",
     [](Clip* c, auto) {
       pointforward::v1::RollingShutter* s = c->mutable_frames(3)->mutable_rolling_shutter();
       *s->mutable_world_from_camera_end() = c->frames(3).world_from_camera();
     },
     "frames[3].rollingShutter.readout", "missing (say which line is read first"},
    {"RollingShutterNegativeReadout",
     [](Clip* c, auto) {
       pointforward::v1::RollingShutter* s = c->mutable_frames(3)->mutable_rolling_shutter();
       s->set_readout(pointforward::v1::RollingShutter::BOTTOM_TO_TOP);
       s->set_readout_us(-5);
       *s->mutable_world_from_camera_end() = c->frames(3).world_from_camera();
     },
     "frames[3].rollingShutter.readoutUs", "must be >= 0 (first line to last), got -5"},
    {"RollingShutterWithoutEndPose",
     [](Clip* c, auto) {
       c->mutable_frames(2)->mutable_rolling_shutter()->set_readout(
           pointforward::v1::RollingShutter::TOP_TO_BOTTOM);
     },
     "frames[2].rollingShutter.worldFromCameraEnd", "missing (16 numbers"},
    {"DepthFileMissing", [](Clip*, const std::string& dir) { Remove(dir + "/depth/front_2.exr"); },
     "frames[4].depth", "file not found"},
    {"DepthSizeDiffers",
     [](Clip*, const std::string& dir) {
       testing::WriteTestDepth(dir + "/depth/front_1.exr", 16, 12);
     },
     "frames[2].depth", "depth map is 16x12 but camera 'front' is 32x24"},
    {"Depth8BitPngRejected",
     [](Clip* c, const std::string& dir) {
       testing::WriteTestImage(dir + "/depth/front_1.png", 32, 24);
       c->mutable_frames(2)->set_depth("depth/front_1.png");
     },
     "frames[2].depth", "depth must be a float EXR or a 16-bit PNG"},
    {"NoContextFrames",
     [](Clip* c, auto) {
       for (Frame& frame : *c->mutable_frames()) frame.set_role(Frame::TARGET);
     },
     "frames", "no CONTEXT frames"},

    // Paths.
    {"PathEscapesByDotDot",
     [](Clip* c, auto) { c->mutable_frames(0)->set_image("images/../../front_0.png"); },
     "frames[0].image", "'images/../../front_0.png' escapes the clip directory"},
    {"PathAbsolute",
     [](Clip* c, const std::string& dir) {
       c->mutable_frames(0)->set_image(dir + "/images/front_0.png");
     },
     "frames[0].image", "is absolute"},
    {"PathEscapesBySymlink",
     [](Clip* c, const std::string& dir) {
       const std::string outside = MakeTempDir("clip_rule_outside");
       testing::WriteTestDepth(outside + "/d.exr", 32, 24);
       fs::create_symlink(outside, dir + "/linked");
       c->mutable_frames(0)->set_depth("linked/d.exr");
     },
     "frames[0].depth", "escapes the clip directory through a symbolic link"},

    // LiDAR.
    {"LidarPointsMissingField", [](Clip* c, auto) { c->mutable_lidar(1)->clear_points(); },
     "lidar[1].points", "missing"},
    {"LidarFileMissing", [](Clip*, const std::string& dir) { Remove(dir + "/lidar/1.bin"); },
     "lidar[1].points", "file not found"},
    {"LidarSizeNotMultipleOf16",
     [](Clip*, const std::string& dir) {
       ASSERT_TRUE(WriteFileAtomic(dir + "/lidar/0.bin", std::string(100, '\0')).ok());
     },
     "lidar[0].points", "file size 100 bytes is not a multiple of 16"},
    {"LidarNonFinitePoint",
     [](Clip*, const std::string& dir) {
       std::string bytes(64, '\0');
       const float nan = std::nanf("");
       std::memcpy(&bytes[16 * 2 + 4], &nan, sizeof(nan));
       ASSERT_TRUE(WriteFileAtomic(dir + "/lidar/0.bin", bytes).ok());
     },
     "lidar[0].points", "1 point(s) have non-finite values (first: point 2)"},
    {"LidarPoseMissing", [](Clip* c, auto) { c->mutable_lidar(0)->clear_world_from_sensor(); },
     "lidar[0].worldFromSensor", "missing"},
    {"LidarPoseNotRigid", [](Clip* c, auto) { c->mutable_lidar(0)->set_world_from_sensor(0, 2); },
     "lidar[0].worldFromSensor", "not a rigid transform (det = 2"},

    // Instances and boxes.
    {"InstanceIdMissing", [](Clip* c, auto) { c->mutable_instances(0)->clear_id(); },
     "instances[0].id", "missing"},
    {"DuplicateInstanceId", [](Clip* c, auto) { *c->add_instances() = c->instances(0); },
     "instances[1].id", "duplicate instance id 'car-1' (also instances[0])"},
    {"InstanceWithoutBoxes", [](Clip* c, auto) { c->mutable_instances(0)->clear_boxes(); },
     "instances[0].boxes", "missing"},
    {"BoxCenterMissing",
     [](Clip* c, auto) { c->mutable_instances(0)->mutable_boxes(1)->clear_center(); },
     "instances[0].boxes[1].center", "missing (3 numbers"},
    {"BoxCenterNaN",
     [](Clip* c, auto) { c->mutable_instances(0)->mutable_boxes(1)->set_center(2, kNaN); },
     "instances[0].boxes[1].center[2]", "not a finite number"},
    {"BoxCenterAbsurd",
     [](Clip* c, auto) { c->mutable_instances(0)->mutable_boxes(1)->set_center(0, -2e7); },
     "instances[0].boxes[1].center[0]",
     "-2e+07 m is beyond the 1e+07 m any world coordinate may have"},
    {"BoxSizeWrongLength",
     [](Clip* c, auto) { c->mutable_instances(0)->mutable_boxes(2)->mutable_size()->RemoveLast(); },
     "instances[0].boxes[2].size", "expected 3 numbers (length, width, height in metres), got 2"},
    {"BoxSizeZero",
     [](Clip* c, auto) { c->mutable_instances(0)->mutable_boxes(1)->set_size(1, 0); },
     "instances[0].boxes[1].size[1]", "box size must be positive, got 0"},
    {"BoxSizeNegative",
     [](Clip* c, auto) { c->mutable_instances(0)->mutable_boxes(0)->set_size(2, -1.5); },
     "instances[0].boxes[0].size[2]", "box size must be positive, got -1.5"},
    {"BoxRotationMissing",
     [](Clip* c, auto) { c->mutable_instances(0)->mutable_boxes(0)->clear_rotation(); },
     "instances[0].boxes[0].rotation", "missing (4 numbers"},
    {"BoxRotationNotUnit",
     [](Clip* c, auto) {
       auto* rotation = c->mutable_instances(0)->mutable_boxes(2)->mutable_rotation();
       rotation->Set(0, 1.0);
       rotation->Set(1, 0.1);
       rotation->Set(2, 0.0);
       rotation->Set(3, 0.0);
     },
     "instances[0].boxes[2].rotation", "not a unit quaternion (norm = 1.00499"},
    {"BoxDuplicateTimestamp",
     [](Clip* c, auto) { c->mutable_instances(0)->mutable_boxes(2)->set_timestamp_us(0); },
     "instances[0].boxes[2].timestampUs", "duplicate timestamp 0 (also boxes[0])"},
};

INSTANTIATE_TEST_SUITE_P(Rules, ClipValidatorRule, ::testing::ValuesIn(kBrokenClips),
                         [](const ::testing::TestParamInfo<BrokenClip>& info) {
                           return info.param.name;
                         });

TEST(ClipValidator, QuaternionWithinToleranceIsAccepted) {
  const std::string dir = MakeTempDir("clip_quat_tol");
  Clip clip = MakeTestClip(dir);
  // Norm 1.0004: within kQuaternionTolerance (rounded numbers from a file).
  auto* rotation = clip.mutable_instances(0)->mutable_boxes(0)->mutable_rotation();
  rotation->Set(0, 1.0004);
  const ClipReport report = Validate(clip, dir);
  EXPECT_TRUE(report.ok()) << Dump(report);
}

}  // namespace
}  // namespace pf
