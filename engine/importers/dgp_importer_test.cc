// Tests of the DGP importer on the real test scene (scene_02: 6 cameras, 3
// time steps, LiDAR, boxes): what lands in the clip, and the conventions
// proved against the scene's own data: 3D boxes projected through our
// cameras onto its 2D boxes, LiDAR depths, points inside boxes, poses.
#include "engine/importers/dgp_importer.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>

#include "common/file_util.h"
#include "engine/camera/camera_model.h"
#include "engine/importers/box_geometry.h"
#include "engine/importers/box_test_util.h"
#include "engine/importers/npy.h"
#include "engine/importers/zip_reader.h"
#include "tests/test_util.h"

namespace pf {
namespace {

namespace fs = std::filesystem;
namespace v1 = pointforward::v1;
using testing::BoxFromProto;
using Json = nlohmann::json;

constexpr char kScene[] = "dgp_test_scene/scene_02";

// The box of `instance` nearest in time to `t`.
const v1::Box& NearestBox(const v1::Instance& instance, int64_t t) {
  const v1::Box* best = &instance.boxes(0);
  for (const auto& b : instance.boxes()) {
    if (std::llabs(b.timestamp_us() - t) < std::llabs(best->timestamp_us() - t)) best = &b;
  }
  return *best;
}

Json LoadJson(const std::string& path) { return Json::parse(*ReadFileToString(path)); }

Rigid PoseOf(const Json& pose) {
  const Json& r = pose["rotation"];
  const Json& t = pose["translation"];
  return {ToMatrix(Quat{r["qw"], r["qx"], r["qy"], r["qz"]}), Vec3{t["x"], t["y"], t["z"]}};
}

// Reads a clip LiDAR sweep (float32 x, y, z, intensity).
std::vector<float> ReadSweep(const std::string& path) {
  const std::string bytes = *ReadFileToString(path);
  std::vector<float> out(bytes.size() / sizeof(float));
  std::memcpy(out.data(), bytes.data(), out.size() * sizeof(float));
  return out;
}

class DgpScene : public ::testing::Test {
 protected:
  // Imports scene_02 once into a temporary directory.
  static void SetUpTestSuite() {
    const auto dir = testing::DataDir(kScene);
    if (!dir) return;
    scene_dir_ = new std::string(*dir);
    out_dir_ = new std::string(testing::MakeTempDir("dgp_import"));
    ImportOptions options;
    options.out_dir = *out_dir_;
    auto result = ImportDgp(*dir, options);
    ASSERT_TRUE(result.ok()) << result.status();
    result_ = new ImportResult(*std::move(result));
  }
  static void TearDownTestSuite() {
    delete scene_dir_;
    delete out_dir_;
    delete result_;
    scene_dir_ = out_dir_ = nullptr;
    result_ = nullptr;
  }

  static std::string* scene_dir_;
  static std::string* out_dir_;
  static ImportResult* result_;
};
std::string* DgpScene::scene_dir_ = nullptr;
std::string* DgpScene::out_dir_ = nullptr;
ImportResult* DgpScene::result_ = nullptr;

TEST(DgpTimestamp, ParsesIsoToMicrosecondsAndRejectsJunk) {
  // The scene's file names are the same microseconds.
  EXPECT_EQ(*ParseDgpTimestamp("2464-11-12T01:04:09.936530Z", "t"), 15616458249936530);
  EXPECT_EQ(*ParseDgpTimestamp("1970-01-01T00:00:01.000001Z", "t"), 1000001);
  const auto bad = ParseDgpTimestamp("yesterday", "id.timestamp");
  EXPECT_EQ(bad.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(std::string(bad.status().message()).find("id.timestamp"), std::string::npos);
}

TEST_F(DgpScene, ImportsSixCamerasThreeTimestampsLidarAndBoxes) {
  PF_REQUIRE_DATA(dir, kScene);
  const v1::Clip& clip = result_->clip;
  EXPECT_EQ(clip.name(), "scene_02");
  ASSERT_EQ(clip.cameras_size(), 6);
  ASSERT_EQ(clip.frames_size(), 18);
  ASSERT_EQ(clip.lidar_size(), 3);
  EXPECT_GE(clip.instances_size(), 10);
  EXPECT_TRUE(result_->warnings.empty());

  // CAMERA_01 intrinsics, as the calibration has them.
  const v1::Camera& cam01 = clip.cameras(0);
  EXPECT_EQ(cam01.id(), "CAMERA_01");
  EXPECT_EQ(cam01.width(), 1936);
  EXPECT_EQ(cam01.height(), 1216);
  EXPECT_DOUBLE_EQ(cam01.intrinsics().fx(), 2181.530254382263);
  EXPECT_DOUBLE_EQ(cam01.intrinsics().cx(), 928.0218817103168);
  EXPECT_DOUBLE_EQ(cam01.intrinsics().cy(), 615.9567879463117);

  // Per camera: frames at ~0, 1, 2 s; the first two are context.
  int context = 0;
  for (const v1::Frame& f : clip.frames()) {
    context += f.role() == v1::Frame::CONTEXT;
    // Timestamps are the source's: the rgb file is named by them.
    const std::string source =
        dir + "/rgb/" + f.camera() + "/" + std::to_string(f.timestamp_us()) + ".jpg";
    ASSERT_TRUE(fs::exists(source)) << source;
    EXPECT_EQ(*ReadFileToString(*out_dir_ + "/" + f.image()), *ReadFileToString(source));
  }
  EXPECT_EQ(context, 12);

  // LiDAR: the points of the first sweep, as float32, in the sensor frame.
  const v1::LidarSweep& sweep = clip.lidar(0);
  EXPECT_EQ(sweep.timestamp_us(), 15616458250027900);
  const std::vector<float> points = ReadSweep(*out_dir_ + "/" + sweep.points());
  auto zip = ZipReader::Open(dir + "/point_cloud/LIDAR/15616458250027900.npz");
  ASSERT_TRUE(zip.ok());
  auto npy = ParseNpy(*zip->Read("data.npy"), "data.npy");
  ASSERT_TRUE(npy.ok());
  ASSERT_EQ(points.size(), npy->data.size());
  for (size_t i : {size_t{0}, size_t{1}, size_t{2}, size_t{3}, points.size() - 1}) {
    EXPECT_FLOAT_EQ(points[i], static_cast<float>(npy->data[i]));
  }
}

// The datum poses are world_from_sensor: a camera's pose equals the LiDAR's
// pose times the calibration's lidar-from-camera (within the car's motion in
// the ~90 ms between the two datums).
TEST_F(DgpScene, DatumPosesAreWorldFromSensor) {
  PF_REQUIRE_DATA(dir, kScene);
  const Json calibration =
      LoadJson(dir + "/calibration/64b9fde6360457d8beddcfb06c512fec6e2989d8.json");
  std::map<std::string, Rigid> vehicle_from_sensor;
  for (size_t i = 0; i < calibration["names"].size(); ++i) {
    vehicle_from_sensor[calibration["names"][i]] = PoseOf(calibration["extrinsics"][i]);
  }
  const v1::Clip& clip = result_->clip;
  int checked = 0;
  for (const v1::Frame& f : clip.frames()) {
    const v1::LidarSweep* sweep = &clip.lidar(0);
    for (const auto& s : clip.lidar()) {
      if (std::llabs(s.timestamp_us() - f.timestamp_us()) <
          std::llabs(sweep->timestamp_us() - f.timestamp_us())) {
        sweep = &s;
      }
    }
    const Rigid world_from_lidar = Rigid::FromRowMajor(sweep->world_from_sensor().data());
    const Rigid predicted =
        world_from_lidar * vehicle_from_sensor["LIDAR"].Inverse() * vehicle_from_sensor[f.camera()];
    const Rigid actual = Rigid::FromRowMajor(f.world_from_camera().data());
    EXPECT_LT(Norm(predicted.translation - actual.translation), 0.3) << f.camera();
    const Mat3 diff = Transpose(predicted.rotation) * actual.rotation;
    const double angle =
        std::acos(std::clamp((diff.m[0][0] + diff.m[1][1] + diff.m[2][2] - 1) / 2, -1.0, 1.0));
    EXPECT_LT(angle, 0.01) << f.camera();
    ++checked;
  }
  EXPECT_EQ(checked, 18);
}

// Projects every 3D box of `clip` through its cameras (after `edit` changes
// them) and compares with the scene's 2D box of the same instance in the
// same image; returns the mean IoU over boxes fully in view and their count.
std::pair<double, int> MeasureIou(const std::string& dir, const v1::Clip& clip,
                                  const std::function<void(v1::Camera*)>& edit,
                                  bool transpose_rotation = false) {
  // (camera, timestamp) -> the bounding_box_2d file of that image datum.
  std::map<std::pair<std::string, int64_t>, std::string> boxes_2d;
  const Json scene = LoadJson(*FindDgpSceneJson(dir));
  for (const Json& d : scene["data"]) {
    if (!d["datum"].contains("image")) continue;
    const int64_t t = *ParseDgpTimestamp(d["id"]["timestamp"], "t");
    boxes_2d[{d["id"]["name"], t}] = d["datum"]["image"]["annotations"]["0"];
  }
  std::map<std::string, const v1::Instance*> instances;
  for (const auto& instance : clip.instances()) instances[instance.id()] = &instance;
  std::map<std::string, CameraModel> models;
  for (v1::Camera c : clip.cameras()) {
    edit(&c);
    models[c.id()] = *CameraModelFromProto(c);
  }
  double sum = 0;
  int count = 0;
  for (const v1::Frame& f : clip.frames()) {
    const auto file = boxes_2d.find({f.camera(), f.timestamp_us()});
    EXPECT_NE(file, boxes_2d.end()) << f.camera() << " " << f.timestamp_us();
    if (file == boxes_2d.end()) continue;
    const Json annotations = LoadJson(dir + "/" + file->second)["annotations"];
    Rigid world_from_camera = Rigid::FromRowMajor(f.world_from_camera().data());
    if (transpose_rotation) world_from_camera.rotation = Transpose(world_from_camera.rotation);
    const Rigid camera_from_world = world_from_camera.Inverse();
    for (const Json& a : annotations) {
      const std::string id = std::to_string(a["instance_id"].get<int64_t>());
      EXPECT_EQ(instances.count(id), 1u) << "2D box of unknown instance " << id;
      if (!instances.count(id)) continue;
      const auto footprint = ProjectBox(BoxFromProto(NearestBox(*instances[id], f.timestamp_us())),
                                        models.at(f.camera()), camera_from_world);
      if (!footprint || !footprint->fully_in_view) continue;
      const Json& b = a["box"];
      const double x = b["x"], y = b["y"], w = b["w"], h = b["h"];
      sum += Iou(footprint->rect, PixelRect{x, y, x + w, y + h});
      ++count;
    }
  }
  return {count ? sum / count : 0.0, count};
}

// Every 3D box projected through our camera model matches the scene's own 2D
// box of the same instance.
TEST_F(DgpScene, Boxes3dProjectOntoTheScenes2dBoxes) {
  PF_REQUIRE_DATA(dir, kScene);
  const auto [mean, count] = MeasureIou(dir, result_->clip, [](v1::Camera*) {});
  std::printf("dgp: %d boxes fully in view, mean IoU %.4f\n", count, mean);
  RecordProperty("mean_iou", std::to_string(mean));
  ASSERT_GT(count, 20);
  EXPECT_GE(mean, 0.7);
}

// The same comparison with a convention broken: the figure drops.
TEST_F(DgpScene, BrokenConventionsLowerTheIou) {
  PF_REQUIRE_DATA(dir, kScene);
  const double good = MeasureIou(dir, result_->clip, [](v1::Camera*) {}).first;
  const double half_pixel = MeasureIou(dir, result_->clip, [](v1::Camera* c) {
                              c->mutable_intrinsics()->set_cx(c->intrinsics().cx() + 0.5);
                              c->mutable_intrinsics()->set_cy(c->intrinsics().cy() + 0.5);
                            }).first;
  const double swapped = MeasureIou(dir, result_->clip, [](v1::Camera* c) {
                           const double cx = c->intrinsics().cx();
                           c->mutable_intrinsics()->set_cx(c->intrinsics().cy());
                           c->mutable_intrinsics()->set_cy(cx);
                         }).first;
  const double focal = MeasureIou(dir, result_->clip, [](v1::Camera* c) {
                         c->mutable_intrinsics()->set_fx(c->intrinsics().fx() * 1.1);
                         c->mutable_intrinsics()->set_fy(c->intrinsics().fy() * 1.1);
                       }).first;
  const double transposed = MeasureIou(
                                dir, result_->clip, [](v1::Camera*) {}, true)
                                .first;
  std::printf(
      "dgp mean IoU: ours %.4f, cx/cy +0.5 %.4f, cx/cy swapped %.4f, focal +10%% %.4f, "
      "rotation transposed %.4f\n",
      good, half_pixel, swapped, focal, transposed);
  EXPECT_LT(half_pixel, good - 0.01);  // Pins the pixel-centre decision.
  EXPECT_LT(transposed, 0.5);
  EXPECT_LT(swapped, 0.5);
  EXPECT_LT(focal, good - 0.02);
}

// LiDAR points land at plausible depths in the front camera, and the points
// inside each box are counted: close to the scene's own num_points, and
// non-zero for every instance that moves.
TEST_F(DgpScene, LidarDepthsArePlausibleAndBoxesHoldPoints) {
  PF_REQUIRE_DATA(dir, kScene);
  const v1::Clip& clip = result_->clip;
  const v1::Camera* front = nullptr;
  for (const auto& c : clip.cameras()) {
    if (c.id() == "CAMERA_01") front = &c;
  }
  ASSERT_NE(front, nullptr);
  const CameraModel model = *CameraModelFromProto(*front);

  std::map<int64_t, std::vector<Vec3>> world_points;  // By sweep timestamp.
  for (const v1::LidarSweep& sweep : clip.lidar()) {
    const Rigid world_from_sensor = Rigid::FromRowMajor(sweep.world_from_sensor().data());
    const std::vector<float> p = ReadSweep(*out_dir_ + "/" + sweep.points());
    auto& out = world_points[sweep.timestamp_us()];
    for (size_t i = 0; i + 3 < p.size(); i += 4)
      out.push_back(world_from_sensor * Vec3{p[i], p[i + 1], p[i + 2]});
  }

  for (const v1::Frame& f : clip.frames()) {
    if (f.camera() != "CAMERA_01") continue;
    const auto nearest = std::min_element(
        world_points.begin(), world_points.end(), [&](const auto& a, const auto& b) {
          return std::llabs(a.first - f.timestamp_us()) < std::llabs(b.first - f.timestamp_us());
        });
    const Rigid camera_from_world = Rigid::FromRowMajor(f.world_from_camera().data()).Inverse();
    std::vector<double> depths;
    for (const Vec3& w : nearest->second) {
      const Vec3 c = camera_from_world * w;
      double u, v;
      if (!model.Project(c, &u, &v)) continue;
      if (u >= 0 && u < model.width() && v >= model.height() / 2.0 && v < model.height()) {
        depths.push_back(c.z);
      }
    }
    ASSERT_GT(depths.size(), 500u);
    std::nth_element(depths.begin(), depths.begin() + depths.size() / 2, depths.end());
    const double median = depths[depths.size() / 2];
    std::printf("dgp: CAMERA_01 at %lld: %zu points in the lower half, median depth %.2f m\n",
                static_cast<long long>(f.timestamp_us()), depths.size(), median);
    EXPECT_GT(median, 2.0);
    EXPECT_LT(median, 80.0);
  }

  // num_points of each LIDAR box annotation, to compare with our counts.
  std::map<std::pair<std::string, int64_t>, int> expected;
  for (const auto& entry : fs::directory_iterator(dir + "/bounding_box_3d/LIDAR")) {
    const int64_t t = std::stoll(entry.path().stem().string());
    const Json file = LoadJson(entry.path().string());
    for (const Json& a : file["annotations"]) {
      expected[{std::to_string(a["instance_id"].get<int64_t>()), t}] = a["num_points"];
    }
  }
  // Counts are proportional to the annotation's num_points: the sample's
  // clouds are thinned by a constant factor, so compare ratios.
  struct Count {
    int inside, annotated;
  };
  std::vector<Count> counts;
  int moving = 0;
  for (const v1::Instance& instance : clip.instances()) {
    const double moved = Norm(BoxFromProto(instance.boxes(instance.boxes_size() - 1)).center -
                              BoxFromProto(instance.boxes(0)).center);
    if (moved > 1.0) ++moving;
    for (const v1::Box& b : instance.boxes()) {
      const OrientedBox box = BoxFromProto(b);
      int inside = 0;
      for (const Vec3& p : world_points.at(b.timestamp_us())) inside += BoxContains(box, p);
      const auto want = expected.find({instance.id(), b.timestamp_us()});
      ASSERT_NE(want, expected.end()) << instance.id() << " at " << b.timestamp_us();
      counts.push_back({inside, want->second});
      if (moved > 1.0) {
        EXPECT_GT(inside, 0) << "moving instance " << instance.id() << " at " << b.timestamp_us();
      }
    }
  }
  double inside_sum = 0, annotated_sum = 0;
  for (const Count& c : counts) {
    inside_sum += c.inside;
    annotated_sum += c.annotated;
  }
  const double ratio = inside_sum / annotated_sum;
  int checked = 0;
  for (const Count& c : counts) {
    if (c.annotated == 0) {
      EXPECT_LE(c.inside, 1);
    }
    if (c.annotated < 100) continue;
    EXPECT_NEAR(c.inside / (ratio * c.annotated), 1.0, 0.35) << c.inside << " vs " << c.annotated;
    ++checked;
  }
  std::printf(
      "dgp: %zu boxes, %.0f points inside them, annotated num_points %.0f (ratio %.3f), "
      "%d moving instances\n",
      counts.size(), inside_sum, annotated_sum, ratio, moving);
  EXPECT_GE(checked, 6);
  EXPECT_GE(moving, 3);
}

TEST(DgpImporter, UnknownCameraIsNamedWithTheAvailableOnes) {
  PF_REQUIRE_DATA(dir, kScene);
  ImportOptions options;
  options.out_dir = testing::MakeTempDir("dgp_bad_camera");
  options.cameras = {"CAMERA_02"};
  const auto result = ImportDgp(dir, options);
  ASSERT_FALSE(result.ok());
  EXPECT_EQ(std::string(result.status().message()),
            "--cameras CAMERA_02: no such camera in the scene (have CAMERA_01, CAMERA_05, "
            "CAMERA_06, CAMERA_07, CAMERA_08, CAMERA_09)");
}

TEST(DgpImporter, CameraSubsetKeepsLidarAndBoxes) {
  PF_REQUIRE_DATA(dir, kScene);
  ImportOptions options;
  options.out_dir = testing::MakeTempDir("dgp_subset");
  options.cameras = {"CAMERA_01"};
  options.roles = RolePolicy::kAllContext;
  const auto result = ImportDgp(dir, options);
  ASSERT_TRUE(result.ok()) << result.status();
  EXPECT_EQ(result->clip.cameras_size(), 1);
  EXPECT_EQ(result->clip.frames_size(), 3);
  EXPECT_EQ(result->clip.lidar_size(), 3);
  for (const auto& f : result->clip.frames()) EXPECT_EQ(f.role(), v1::Frame::CONTEXT);
}

TEST(DgpImporter, MissingReferencedFileIsNamed) {
  PF_REQUIRE_DATA(dir, kScene);
  // A copy of the scene's JSON files without its images and point clouds.
  const std::string copy = testing::MakeTempDir("dgp_missing");
  const std::string scene_json = *FindDgpSceneJson(dir);
  fs::copy_file(scene_json, copy + "/" + fs::path(scene_json).filename().string());
  fs::copy(dir + "/calibration", copy + "/calibration");
  fs::copy(dir + "/ontology", copy + "/ontology");
  ImportOptions options;
  options.out_dir = copy + "/out";
  const auto result = ImportDgp(copy, options);
  ASSERT_FALSE(result.ok());
  EXPECT_EQ(result.status().code(), absl::StatusCode::kNotFound);
  const std::string message(result.status().message());
  EXPECT_NE(message.find("references point_cloud/LIDAR/15616458250027900.npz, which is missing"),
            std::string::npos)
      << message;
}

TEST(DgpImporter, MissingSceneDirectory) {
  ImportOptions options;
  options.out_dir = testing::MakeTempDir("dgp_none");
  const auto result = ImportDgp("/nonexistent/scene", options);
  EXPECT_EQ(result.status().code(), absl::StatusCode::kNotFound);
}

}  // namespace
}  // namespace pf
