// Tests of RenderViews parsing: values carried through, errors naming fields.
#include "engine/render/views.h"

#include <gtest/gtest.h>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_replace.h"
#include "common/file_util.h"
#include "engine/clip/clip_io.h"
#include "tests/test_util.h"

namespace pf {
namespace {

GaussianScene SceneWithInstances() {
  GaussianScene scene;
  for (const char* id : {"car1", "ped2"}) {
    InstanceTrack track;
    track.id = id;
    track.boxes.push_back({0, {0, 0, 0}, {1, 1, 1}, {}});
    scene.instances.push_back(track);
  }
  return scene;
}

constexpr char kIdentity[] = "[1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]";

// A valid request; tests replace parts of it with `$NAME` placeholders.
std::string ValidJson() {
  return absl::StrCat(R"({
  "cameras": [
    {"id": "front", "width": 64, "height": 48, "intrinsics": {"fx": 50, "fy": 51, "cx": 32, "cy": 24}},
    {"id": "side", "width": 32, "height": 32, "intrinsics": {"fx": 20, "fy": 20, "cx": 16, "cy": 16},
     "distortion": {"model": "OPENCV", "k1": -0.1, "k2": 0.01, "p1": 0.001, "p2": -0.002, "k3": 0.0001}}
  ],
  "views": [
    {"camera": "front", "timestampUs": "1700000000000001", "worldFromCamera": [0,0,1,5, -1,0,0,2, 0,-1,0,1.5, 0,0,0,1]},
    {"camera": "side", "timestampUs": 42, "worldFromCamera": )",
                      kIdentity, R"(, "name": "side_view"}
  ],
  "edits": [
    {"instance": "ped2", "kind": "REMOVE"},
    {"instance": "car1", "kind": "TRAJECTORY", "boxes": [
      {"timestampUs": 200, "center": [2, 0, 0], "rotation": [2, 0, 0, 0]},
      {"timestampUs": 100, "center": [1, 0, 0], "rotation": [1, 0, 0, 0], "size": [4, 2, 1.5]}
    ]}
  ]
})");
}

TEST(RenderViews, ParsesCamerasViewsAndEdits) {
  absl::StatusOr<RenderRequest> request = ParseRenderViews(ValidJson(), SceneWithInstances());
  ASSERT_TRUE(request.ok()) << request.status();
  ASSERT_EQ(request->views.size(), 2u);
  const RenderView& front = request->views[0];
  EXPECT_EQ(front.name, "front_1700000000000001");  // Default name.
  EXPECT_EQ(front.camera_id, "front");
  EXPECT_EQ(front.timestamp_us, 1700000000000001);
  EXPECT_EQ(front.camera_model, "pinhole");
  EXPECT_TRUE(front.distortion.empty());
  EXPECT_EQ(front.camera.model.width(), 64);
  EXPECT_EQ(front.camera.model.fy(), 51);
  EXPECT_EQ(front.camera.world_from_camera.translation.x, 5);
  EXPECT_EQ(front.camera.world_from_camera.translation.z, 1.5);
  // Camera z (forward) is world x.
  EXPECT_NEAR(front.camera.world_from_camera.rotation.m[0][2], 1, 1e-12);
  const RenderView& side = request->views[1];
  EXPECT_EQ(side.name, "side_view");
  EXPECT_EQ(side.camera_model, "opencv");
  EXPECT_EQ(side.camera.model.kind(), CameraModel::Kind::kOpenCv);
  EXPECT_EQ(side.distortion, (std::vector<double>{-0.1, 0.01, 0.001, -0.002, 0.0001}));

  ASSERT_EQ(request->edits.size(), 2u);
  EXPECT_EQ(request->edits[0].kind, ActorEdit::Kind::kRemove);
  EXPECT_EQ(request->edits[0].instance_id, "ped2");
  const ActorEdit& trajectory = request->edits[1];
  EXPECT_EQ(trajectory.kind, ActorEdit::Kind::kTrajectory);
  ASSERT_EQ(trajectory.boxes.size(), 2u);
  EXPECT_EQ(trajectory.boxes[0].timestamp_us, 100);  // Sorted by time.
  EXPECT_EQ(trajectory.boxes[0].center.x, 1);
  EXPECT_EQ(trajectory.boxes[0].size.x, 4);
  EXPECT_EQ(trajectory.boxes[1].rotation.w, 1);  // Normalised from (2, 0, 0, 0).
}

// Returns the error message of ValidJson() with `from` replaced by `to`.
std::string ErrorFor(const std::string& from, const std::string& to) {
  std::string json = ValidJson();
  const size_t at = json.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  json.replace(at, from.size(), to);
  absl::StatusOr<RenderRequest> request = ParseRenderViews(json, SceneWithInstances());
  EXPECT_EQ(request.status().code(), absl::StatusCode::kInvalidArgument);
  return std::string(request.status().message());
}

TEST(RenderViews, ErrorsNameTheField) {
  EXPECT_EQ(ErrorFor(R"("camera": "side")", R"("camera": "x")"),
            "views[1].camera: unknown camera 'x'");
  EXPECT_EQ(ErrorFor(R"("instance": "car1")", R"("instance": "car9")"),
            "edits[1].instance: unknown instance 'car9'");
  EXPECT_EQ(ErrorFor(R"("instance": "car1")", R"("instance": "ped2")"),
            "edits[1].instance: instance 'ped2' is edited twice");
  EXPECT_EQ(ErrorFor(R"("kind": "REMOVE")", R"("kind": "KIND_UNSPECIFIED")"),
            "edits[0].kind: must be REMOVE or TRAJECTORY");
  EXPECT_EQ(ErrorFor(R"("center": [2, 0, 0])", R"("center": [2, 0])"),
            "edits[1].boxes[0].center: expected 3 numbers, got 2");
  EXPECT_EQ(ErrorFor(R"("rotation": [2, 0, 0, 0])", R"("rotation": [0, 0, 0, 0])"),
            "edits[1].boxes[0].rotation: zero or non-finite quaternion");
  EXPECT_EQ(ErrorFor(R"("timestampUs": 200)", R"("timestampUs": 100)"),
            "edits[1].boxes: two boxes at timestampUs 100");
  EXPECT_EQ(ErrorFor(R"("name": "side_view")", R"("name": "../etc")"),
            "views[1].name: '../etc' is not a usable file name (letters, digits, '_', '-', '.')");
  EXPECT_EQ(ErrorFor(R"("name": "side_view")", R"("name": "front_1700000000000001")"),
            "views[1].name: duplicate output name 'front_1700000000000001'");
  EXPECT_EQ(ErrorFor(R"("id": "side")", R"("id": "front")"),
            "cameras[1].id: duplicate camera id 'front'");
  EXPECT_NE(ErrorFor(R"("width": 32)", R"("width": 0)")
                .find("cameras[1]: camera 'side': width and height must be positive"),
            std::string::npos);
  EXPECT_NE(ErrorFor("[0,0,1,5, -1,0,0,2", "[0,0,2,5, -1,0,0,2")
                .find("views[0].worldFromCamera: not a rigid transform"),
            std::string::npos);
  EXPECT_EQ(ErrorFor("[0,0,1,5, -1,0,0,2, 0,-1,0,1.5, 0,0,0,1]", "[1,0,0,0]"),
            "views[0].worldFromCamera: expected 16 numbers (4x4 row-major), got 4");
  // JSON-level problems read as the clip manifest's do: field paths in
  // JSON names, a suggestion for a misspelt field.
  EXPECT_EQ(ErrorFor(R"("timestampUs": 42)", R"("timestampUs": 42, "nmae": "x")"),
            "not a RenderViews JSON: views[1].nmae: unknown field (did you mean 'name'?)");
  EXPECT_NE(ErrorFor(R"("timestampUs": 42)", R"("timestampUs": "abc")")
                .find("not a RenderViews JSON: views[1].timestampUs: "),
            std::string::npos);
  EXPECT_NE(ErrorFor(R"("edits": [)", R"("edits": {)").find("not a RenderViews JSON"),
            std::string::npos);
}

TEST(RenderViews, FromProtoChecksEditsAgainstTheInstancesGivenOrNone) {
  pointforward::v1::RenderViews message;
  ASSERT_TRUE(ParseJsonMessage(ValidJson(), &message).ok());
  message.mutable_edits(0)->set_instance("bus7");  // Not an instance of the scene.
  const std::vector<std::string> ids = InstanceIds(SceneWithInstances());
  EXPECT_EQ(ids, (std::vector<std::string>{"car1", "ped2"}));
  EXPECT_EQ(RenderRequestFromProto(message, ids).status().message(),
            "edits[0].instance: unknown instance 'bus7'");
  // Before the scene exists any instance may be named, still once only.
  absl::StatusOr<RenderRequest> any = RenderRequestFromProto(message, std::nullopt);
  ASSERT_TRUE(any.ok()) << any.status();
  ASSERT_EQ(any->edits.size(), 2u);
  EXPECT_EQ(any->edits[0].instance_id, "bus7");
  EXPECT_EQ(any->views.size(), 2u);
  message.mutable_edits(1)->set_instance("bus7");
  EXPECT_EQ(RenderRequestFromProto(message, std::nullopt).status().message(),
            "edits[1].instance: instance 'bus7' is edited twice");
}

TEST(RenderViews, AbsurdTranslationsAndCentresAreRefused) {
  // Finite, but no world frame reaches 1e308 m: refused here, not found by
  // the rasterizer's arithmetic on a worker.
  EXPECT_EQ(ErrorFor("[0,0,1,5, -1,0,0,2", "[0,0,1,1e308, -1,0,0,2"),
            "views[0].worldFromCamera[3]: 1e+308 m is beyond the 1e+07 m any world coordinate "
            "may have");
  EXPECT_EQ(ErrorFor(R"("center": [2, 0, 0])", R"("center": [2, -3e7, 0])"),
            "edits[1].boxes[0].center[1]: -3e+07 m is beyond the 1e+07 m any world coordinate "
            "may have");
  // Large but plausible: accepted.
  std::string json = ValidJson();
  json.replace(json.find("[0,0,1,5,"), 9, "[0,0,1,9.9e6,");
  EXPECT_TRUE(ParseRenderViews(json, SceneWithInstances()).ok());
}

TEST(RenderViews, CarriesFisheyeCoefficients) {
  const std::string json = R"({
    "cameras": [{"id": "fish", "width": 32, "height": 32,
                 "intrinsics": {"fx": 10, "fy": 10, "cx": 16, "cy": 16},
                 "distortion": {"model": "FISHEYE", "k1": 0.1, "k2": -0.02, "k3": 0.003, "k4": -0.0004}}],
    "views": [{"camera": "fish", "timestamp_us": 7, "world_from_camera": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]}]
  })";
  absl::StatusOr<RenderRequest> request = ParseRenderViews(json, GaussianScene{});
  ASSERT_TRUE(request.ok()) << request.status();
  const RenderView& view = request->views[0];
  EXPECT_EQ(view.name, "fish_7");
  EXPECT_EQ(view.camera_model, "fisheye");
  EXPECT_EQ(view.camera.model.kind(), CameraModel::Kind::kFisheye);
  EXPECT_EQ(view.distortion, (std::vector<double>{0.1, -0.02, 0.003, -0.0004}));
  EXPECT_TRUE(request->edits.empty());

  // A default name is made fit for a file. (`view` refers into the first
  // result, so it is checked above, before `request` is replaced.)
  std::string renamed = json;
  renamed.replace(renamed.find(R"("camera": "fish")"), 16, R"("camera": "fish/left")");
  renamed.replace(renamed.find(R"("id": "fish")"), 12, R"("id": "fish/left")");
  request = ParseRenderViews(renamed, GaussianScene{});
  ASSERT_TRUE(request.ok()) << request.status();
  EXPECT_EQ(request->views[0].name, "fish_left_7");
}

TEST(RenderViews, CarriesFThetaPolynomialsAndNamesTheirFaults) {
  // Given as the inverse (pixels to angle) only, 0.01 rad per pixel: the
  // view carries the fitted angle-to-pixel polynomial, 100 px per radian.
  const std::string json = R"({
    "cameras": [{"id": "surround", "width": 64, "height": 48, "intrinsics": {"cx": 32, "cy": 24},
                 "distortion": {"model": "FTHETA", "fthetaInversePoly": [0, 0.01]}}],
    "views": [{"camera": "surround", "timestamp_us": 7, "world_from_camera": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]}]
  })";
  absl::StatusOr<RenderRequest> request = ParseRenderViews(json, GaussianScene{});
  ASSERT_TRUE(request.ok()) << request.status();
  const RenderView& view = request->views[0];
  EXPECT_EQ(view.camera_model, "ftheta");
  EXPECT_EQ(view.camera.model.kind(), CameraModel::Kind::kFTheta);
  ASSERT_EQ(view.distortion.size(), 6u);
  EXPECT_NEAR(view.distortion[0], 0, 1e-9);
  EXPECT_NEAR(view.distortion[1], 100, 1e-6);
  for (int i = 2; i < 6; ++i) EXPECT_NEAR(view.distortion[i], 0, 1e-6) << i;
  EXPECT_NEAR(view.camera.model.fx(), 100, 1e-6);

  std::string bad = json;
  const std::string inverse = R"("fthetaInversePoly": [0, 0.01])";
  bad.replace(bad.find(inverse), inverse.size(), R"("fthetaPoly": [1, 100])");
  request = ParseRenderViews(bad, GaussianScene{});
  ASSERT_FALSE(request.ok());
  EXPECT_NE(request.status().message().find(
                "cameras[0]: camera 'surround'.distortion.fthetaPoly[0]: must be 0"),
            std::string::npos)
      << request.status();
}

TEST(RenderViews, RejectsAnEmptyViewList) {
  absl::StatusOr<RenderRequest> request = ParseRenderViews("{}", SceneWithInstances());
  EXPECT_EQ(request.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(request.status().message(), "views: no views or lidars to render");
}

TEST(RenderViews, LoadPrefixesErrorsWithThePath) {
  const std::string path = testing::MakeTempDir("views") + "/views.json";
  EXPECT_EQ(LoadRenderViews(path, SceneWithInstances()).status().code(),
            absl::StatusCode::kNotFound);
  std::string json = ValidJson();
  json.replace(json.find(R"("camera": "side")"), 16, R"("camera": "rear")");
  ASSERT_TRUE(WriteFileAtomic(path, json).ok());
  EXPECT_EQ(LoadRenderViews(path, SceneWithInstances()).status().message(),
            absl::StrCat(path, ": views[1].camera: unknown camera 'rear'"));
  ASSERT_TRUE(WriteFileAtomic(path, ValidJson()).ok());
  absl::StatusOr<RenderRequest> request = LoadRenderViews(path, SceneWithInstances());
  ASSERT_TRUE(request.ok()) << request.status();
  EXPECT_EQ(request->views.size(), 2u);
}

TEST(RenderViews, ARollingShutterIsReadAndItsBadFieldsNamed) {
  GaussianScene scene;
  const std::string view = R"({
    "cameras": [{"id": "c", "width": 8, "height": 8,
                 "intrinsics": {"fx": 8, "fy": 8, "cx": 4, "cy": 4}}],
    "views": [{"camera": "c", "worldFromCamera": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1],
               "rollingShutter": {$SHUTTER}}]})";
  auto parse = [&](const std::string& shutter) {
    std::string json = view;
    json.replace(json.find("$SHUTTER"), 8, shutter);
    return ParseRenderViews(json, scene);
  };
  absl::StatusOr<RenderRequest> request = parse(
      R"("readout": "BOTTOM_TO_TOP", "readoutUs": 30000,
         "worldFromCameraEnd": [1,0,0,0.5, 0,1,0,0, 0,0,1,0, 0,0,0,1])");
  ASSERT_TRUE(request.ok()) << request.status();
  const std::optional<RollingShutter>& shutter = request->views[0].camera.rolling_shutter;
  ASSERT_TRUE(shutter.has_value());
  EXPECT_EQ(shutter->readout, RollingShutter::Readout::kBottomToTop);
  EXPECT_EQ(shutter->readout_us, 30000);
  EXPECT_EQ(shutter->world_from_camera_end.translation.x, 0.5);
  EXPECT_EQ(parse(R"("readoutUs": 1, "worldFromCameraEnd": )" + std::string(kIdentity))
                .status()
                .message(),
            "views[0].rollingShutter.readout: say which line is read first: TOP_TO_BOTTOM, "
            "BOTTOM_TO_TOP, LEFT_TO_RIGHT or RIGHT_TO_LEFT");
  EXPECT_EQ(parse(R"("readout": "TOP_TO_BOTTOM", "readoutUs": -1, "worldFromCameraEnd": )" +
                  std::string(kIdentity))
                .status()
                .message(),
            "views[0].rollingShutter.readoutUs: must be >= 0, got -1");
  EXPECT_NE(parse(R"("readout": "TOP_TO_BOTTOM")")
                .status()
                .message()
                .find("views[0].rollingShutter.worldFromCameraEnd: expected 16 numbers"),
            std::string::npos);
  // Without one, the whole image is at one pose.
  request = ParseRenderViews(ValidJson(), SceneWithInstances());
  ASSERT_TRUE(request.ok()) << request.status();
  EXPECT_FALSE(request->views[0].camera.rolling_shutter.has_value());
}

TEST(RenderViews, LidarsTakeDefaultsAndNameBadFields) {
  GaussianScene scene;
  absl::StatusOr<RenderRequest> request = ParseRenderViews(R"({
    "lidars": [{"spec": {"beamElevationsDeg": [0, -5]}, "timestampUs": 1000,
                "worldFromSensor": [1,0,0,0, 0,1,0,0, 0,0,1,1.8, 0,0,0,1]}]})",
                                                           scene);
  ASSERT_TRUE(request.ok()) << request.status();
  ASSERT_EQ(request->lidars.size(), 1u);
  const LidarRenderView& lidar = request->lidars[0];
  EXPECT_EQ(lidar.name, "lidar_1000");
  EXPECT_EQ(lidar.spec.azimuth_resolution_deg, 0.2);
  EXPECT_EQ(lidar.spec.rotation_hz, 10);
  EXPECT_EQ(lidar.pose.start_us, 1000);
  EXPECT_EQ(lidar.pose.end_us, 101000);
  EXPECT_EQ(lidar.pose.world_from_sensor_end.translation.z, 1.8);  // At rest.

  absl::StatusOr<RenderRequest> bad = ParseRenderViews(R"({
    "lidars": [{"spec": {"beamElevationsDeg": [0], "rotationHz": -1},
                "worldFromSensor": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]}]})",
                                                       scene);
  EXPECT_EQ(bad.status().message(), "lidars[0].spec.rotationHz: must be in (0, 100], got -1");
  bad = ParseRenderViews(R"({"lidars": [{"spec": {"beamElevationsDeg": [0]},
                                          "worldFromSensor": [1, 0]}]})",
                         scene);
  EXPECT_NE(bad.status().message().find("lidars[0].worldFromSensor: expected 16 numbers"),
            std::string::npos);
  // A sweep's files may not be a view's: view "top.range" writes top.range.exr.
  bad = ParseRenderViews(R"({
    "cameras": [{"id": "c", "width": 8, "height": 8,
                 "intrinsics": {"fx": 8, "fy": 8, "cx": 4, "cy": 4}}],
    "views": [{"name": "top.range", "camera": "c",
               "worldFromCamera": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]}],
    "lidars": [{"name": "top", "spec": {"beamElevationsDeg": [0]},
                "worldFromSensor": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]}]})",
                         scene);
  EXPECT_EQ(bad.status().message(),
            "lidars[0].name: output file 'top.range.exr' is another view's or sweep's");
}

}  // namespace
}  // namespace pf
