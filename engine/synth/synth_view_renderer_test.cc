// Tests of `pf synth render`'s engine: request checks that name the field,
// and renders at new poses with actor edits.
#include "engine/synth/synth_view_renderer.h"

#include <gtest/gtest.h>

#include "absl/strings/str_cat.h"
#include "common/file_util.h"
#include "engine/image/image_io.h"
#include "engine/synth/synth_params.h"
#include "tests/test_util.h"

namespace pf {
namespace {

namespace v1 = pointforward::v1;

SynthOptions SmallRendererOptions() {
  SynthOptions options;
  options.seed = 2;
  options.num_frames = 6;
  options.width = 96;
  options.height = 72;
  options.antialias = 1;
  return options;
}

SynthScene SmallRendererScene() {
  auto scene = GenerateSynthScene(SmallRendererOptions());
  EXPECT_TRUE(scene.ok());
  return *scene;
}

// Returns the row-major pose JSON of `pose`.
std::string PoseJson(const Rigid& pose) {
  std::string out = "[";
  const auto values = pose.ToRowMajor();
  for (size_t i = 0; i < values.size(); ++i) absl::StrAppend(&out, i ? ", " : "", values[i]);
  return out + "]";
}

std::string ResolveError(const std::string& json) {
  auto request = ParseRenderViews(json, "views.json");
  if (!request.ok()) return std::string(request.status().message());
  const auto resolved = ResolveViews(*request, SmallRendererScene());
  return resolved.ok() ? "" : std::string(resolved.status().message());
}

TEST(SynthViewRenderer, RollingShuttersAreCheckedAndReadLineByLine) {
  const SynthScene scene = SmallRendererScene();
  const std::string pose = PoseJson(scene.WorldFromCamera(1, 0));
  auto view = [&](const std::string& shutter) {
    return R"({"views": [{"camera": "cam_front", "worldFromCamera": )" + pose +
           R"(, "rollingShutter": {)" + shutter + "}}]}";
  };
  EXPECT_EQ(ResolveError(view(R"("readoutUs": 10, "worldFromCameraEnd": )" + pose)),
            "views[0].rollingShutter.readout: say which line is read first");
  EXPECT_EQ(ResolveError(view(R"("readout": "LEFT_TO_RIGHT", "readoutUs": -5)")),
            "views[0].rollingShutter.readoutUs: must be >= 0, got -5");
  EXPECT_EQ(ResolveError(view(R"("readout": "LEFT_TO_RIGHT")")),
            "views[0].rollingShutter.worldFromCameraEnd: expected 16 numbers, got 0");

  // A readout that neither moves nor takes time, read line by line, is the
  // whole-image render; one that moves is not.
  const std::string dir = testing::MakeTempDir("synth_rolling");
  const SynthOptions options = SmallRendererOptions();
  ASSERT_TRUE(WriteFileAtomic(dir + "/synth.json", SynthParamsToJson(options)).ok());
  Rigid moved = scene.WorldFromCamera(1, 0);
  moved.translation = moved.translation + moved.rotation * Vec3{0.5, 0, 0};
  const std::string views =
      R"({"views": [{"camera": "cam_front", "name": "global", "worldFromCamera": )" + pose +
      R"(}, {"camera": "cam_front", "name": "still", "worldFromCamera": )" + pose +
      R"(, "rollingShutter": {"readout": "BOTTOM_TO_TOP", "worldFromCameraEnd": )" + pose +
      R"(}}, {"camera": "cam_front", "name": "moving", "worldFromCamera": )" + pose +
      R"(, "rollingShutter": {"readout": "LEFT_TO_RIGHT", "readoutUs": 30000, )" +
      R"("worldFromCameraEnd": )" + PoseJson(moved) + "}}]}";
  ASSERT_TRUE(WriteFileAtomic(dir + "/views.json", views).ok());
  ASSERT_TRUE(RenderSynthViews(dir, dir + "/views.json", dir + "/out").ok());
  absl::StatusOr<ImageF> global = ReadDepth(dir + "/out/global.exr");
  absl::StatusOr<ImageF> still = ReadDepth(dir + "/out/still.exr");
  absl::StatusOr<ImageF> moving = ReadDepth(dir + "/out/moving.exr");
  ASSERT_TRUE(global.ok() && still.ok() && moving.ok());
  double still_error = 0, left_error = 0, right_error = 0;
  for (int y = 0; y < global->height; ++y) {
    for (int x = 0; x < global->width; ++x) {
      still_error = std::max(still_error, std::abs(double(still->at(x, y)) - global->at(x, y)) /
                                              std::max(1.0, double(global->at(x, y))));
      (x < 4 ? left_error : right_error) +=
          x < 4 || x >= global->width - 4 ? std::abs(moving->at(x, y) - global->at(x, y)) : 0;
    }
  }
  EXPECT_LT(still_error, 1e-3);  // Relative: the rays to float rounding.
  // The first columns are read at the view's pose, the last 0.5 m to its right.
  EXPECT_LT(left_error, 0.1 * right_error);
  EXPECT_GT(right_error, 0);
}

TEST(SynthViewRenderer, ErrorsNameTheField) {
  const SynthScene scene = SmallRendererScene();
  const std::string pose = PoseJson(scene.WorldFromCamera(1, 0));
  const std::string view = R"({"camera": "cam_front", "worldFromCamera": )" + pose + "}";
  EXPECT_EQ(ResolveError(R"({"views": [)" + view + "]}"), "");

  EXPECT_EQ(ResolveError(R"({"views": [)" + view + R"(, {"camera": "x", "worldFromCamera": )" +
                         pose + "}]}"),
            "views[1].camera: unknown camera 'x'");
  EXPECT_EQ(ResolveError(R"({"views": [{"camera": "cam_front", "worldFromCamera": [1, 0]}]})"),
            "views[0].worldFromCamera: expected 16 numbers, got 2");
  EXPECT_NE(ResolveError(R"({"views": [{"camera": "cam_front", "worldFromCamera": )"
                         "[2,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]}]}")
                .find("views[0].worldFromCamera: not a rigid transform (det = 2)"),
            std::string::npos);
  EXPECT_EQ(ResolveError(R"({"views": [)" + view + "," + view + "]}"),
            "views[1].name: duplicate output name 'cam_front_0'");
  EXPECT_EQ(
      ResolveError(R"({"views": [{"camera": "cam_front", "name": "../x", "worldFromCamera": )" +
                   pose + "}]}"),
      "views[0].name: '../x' is not a plain file name");
  EXPECT_EQ(ResolveError(R"({"views": []})"), "views: no views to render");
  EXPECT_EQ(ResolveError(R"({"views": [)" + view +
                         R"(], "edits": [{"instance": "vehicle_9", "kind": "REMOVE"}]})"),
            "edits[0].instance: unknown instance 'vehicle_9'");
  EXPECT_EQ(ResolveError(R"({"views": [)" + view + R"(], "edits": [{"instance": "vehicle_1"}]})"),
            "edits[0].kind: must be REMOVE or TRAJECTORY");
  EXPECT_EQ(ResolveError(R"({"views": [)" + view +
                         R"(], "edits": [{"instance": "vehicle_1", "kind": "TRAJECTORY"}]})"),
            "edits[0].boxes: TRAJECTORY needs at least one box");
  EXPECT_EQ(ResolveError(R"({"views": [)" + view +
                         R"(], "edits": [{"instance": "vehicle_1", "kind": "TRAJECTORY", )"
                         R"("boxes": [{"center": [1, 2, 3], "rotation": [2, 0, 0, 0]}]}]})"),
            "edits[0].boxes[0].rotation: not a unit quaternion (norm = 2)");
  EXPECT_EQ(ResolveError(R"({"cameras": [{"id": "c", "width": 0, "height": 10}], "views": [)" +
                         view + "]}"),
            "cameras[0]: camera 'c': width and height must be positive");
  EXPECT_EQ(ResolveError(R"({"cameras": [{"id": "c", "width": 100000, "height": 10}], "views": [)" +
                         view + "]}"),
            "cameras[0]: image size 100000x10 exceeds 16384 pixels a side");
  EXPECT_NE(ResolveError(R"({"views": [{"camera": "cam_front", "bogus": 1}]})")
                .find("views.json: not a RenderViews message"),
            std::string::npos);
}

TEST(SynthViewRenderer, ResolvesCamerasOfTheRequestAndOfTheClip) {
  const std::string json = R"({"cameras": [{"id": "wide", "width": 64, "height": 32,
      "intrinsics": {"fx": 20, "fy": 20, "cx": 32, "cy": 16}}],
    "views": [{"camera": "wide", "timestampUs": "250000", "name": "a",
               "worldFromCamera": [1,0,0,0, 0,1,0,0, 0,0,1,2, 0,0,0,1]},
              {"camera": "cam_left", "worldFromCamera": [1,0,0,0, 0,1,0,0, 0,0,1,2, 0,0,0,1]}]})";
  auto request = ParseRenderViews(json, "v.json");
  ASSERT_TRUE(request.ok()) << request.status();
  const auto resolved = ResolveViews(*request, SmallRendererScene());
  ASSERT_TRUE(resolved.ok()) << resolved.status();
  ASSERT_EQ(resolved->views.size(), 2u);
  EXPECT_EQ(resolved->views[0].name, "a");
  EXPECT_EQ(resolved->views[0].camera.width(), 64);
  EXPECT_DOUBLE_EQ(resolved->views[0].time_s, 0.25);
  EXPECT_EQ(resolved->views[1].name, "cam_left_0");
  EXPECT_EQ(resolved->views[1].camera.width(), 96);
}

// A lane-shifted view with a removed vehicle: files at the requested names,
// depth equal to the ray caster's at that pose, and the removed vehicle gone.
TEST(SynthViewRenderer, RendersShiftedViewsWithEdits) {
  const std::string clip_dir = testing::MakeTempDir("synth_render_clip");
  const SynthOptions options = SmallRendererOptions();
  ASSERT_TRUE(WriteFileAtomic(clip_dir + "/synth.json", SynthParamsToJson(options)).ok());
  const SynthScene scene = SmallRendererScene();
  const double t = 0.5;
  Rigid shifted = scene.WorldFromCamera(1, t);
  shifted.translation.y += 3.5;  // One lane to the left.
  const std::string pose = PoseJson(shifted);
  const std::string views_path = clip_dir + "/views.json";
  const std::string views =
      R"({"views": [{"camera": "cam_front", "timestampUs": "500000", "name": "shifted", )"
      R"("worldFromCamera": )" +
      pose +
      R"(}, {"camera": "cam_front", "timestampUs": 500000, )"
      R"("name": "shifted_no_car", "worldFromCamera": )" +
      pose + R"(}]})";
  ASSERT_TRUE(WriteFileAtomic(views_path, views).ok());
  const std::string out = testing::MakeTempDir("synth_render_out");
  auto names = RenderSynthViews(clip_dir, views_path, out + "/a");
  ASSERT_TRUE(names.ok()) << names.status();
  EXPECT_EQ(*names, (std::vector<std::string>{"shifted", "shifted_no_car"}));

  const auto depth = ReadDepth(out + "/a/shifted.exr");
  ASSERT_TRUE(depth.ok()) << depth.status();
  const RenderedView expected =
      RenderView(SnapshotAt(scene, t), scene.cameras[1].model, shifted, 1);
  for (size_t i = 0; i < expected.depth.pixels.size(); ++i) {
    ASSERT_NEAR(depth->pixels[i], expected.depth.pixels[i], 1e-5 * (1 + expected.depth.pixels[i]));
  }
  ASSERT_TRUE(ReadImageInfo(out + "/a/shifted.png").ok());

  // Now remove the vehicle ahead: its pixels become farther (or sky).
  const std::string with_edit = views.substr(0, views.size() - 1) +
                                R"(, "edits": [{"instance": "vehicle_1", "kind": "REMOVE"}]})";
  ASSERT_TRUE(WriteFileAtomic(views_path, with_edit).ok());
  names = RenderSynthViews(clip_dir, views_path, out + "/b");
  ASSERT_TRUE(names.ok()) << names.status();
  const auto removed = ReadDepth(out + "/b/shifted_no_car.exr");
  ASSERT_TRUE(removed.ok());
  int vehicle_pixels = 0;
  for (size_t i = 0; i < expected.instance.size(); ++i) {
    if (expected.instance[i] != 1) {
      ASSERT_NEAR(removed->pixels[i], expected.depth.pixels[i],
                  1e-5 * (1 + expected.depth.pixels[i]));
      continue;
    }
    ++vehicle_pixels;
    EXPECT_TRUE(removed->pixels[i] == 0.f || removed->pixels[i] > expected.depth.pixels[i]);
  }
  EXPECT_GT(vehicle_pixels, 10);
}

TEST(SynthViewRenderer, MissingSynthJsonSaysWhatIsWrong) {
  const std::string dir = testing::MakeTempDir("synth_render_missing");
  const auto status = RenderSynthViews(dir, dir + "/views.json", dir + "/out").status();
  EXPECT_TRUE(absl::IsNotFound(status)) << status;
  EXPECT_NE(std::string(status.message()).find("synth.json: not found"), std::string::npos)
      << status;
}

}  // namespace
}  // namespace pf
