// Tests of the PandaSet importer on the sample sequence (frames 46-47 of
// sequence 002: 6 cameras, LiDAR, cuboids): what lands in the clip, and the
// conventions proved against the data itself: LiDAR depth edges meet image
// edges (and stop meeting them when a convention is broken), moving boxes
// hold their LiDAR points (and lose them when the box convention is
// broken), boxes seen by both LiDARs are kept once. The pickle reader runs
// from the source tree (pandaset_pickles.py beside this file).
#include "engine/importers/pandaset_importer.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <functional>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>

#include "common/file_util.h"
#include "engine/camera/camera_model.h"
#include "engine/image/image_io.h"
#include "engine/importers/box_geometry.h"
#include "engine/importers/box_test_util.h"
#include "engine/importers/npy.h"
#include "tests/test_util.h"

namespace pf {
namespace {

namespace v1 = pointforward::v1;
using testing::BoxFromProto;

constexpr char kSequence[] = "pandaset_002";
// Frames 46 and 47: the car moves about 0.45 m per frame, so a time offset
// of one frame (100 ms) moves the cameras visibly.
constexpr int kFirstFrame = 46;
constexpr int kEndFrame = 48;

std::string PicklesModule() {
  return testing::SourceDir() + "/engine/importers/pandaset_pickles.py";
}

nlohmann::json PandasetJson(const std::string& path) {
  return nlohmann::json::parse(*ReadFileToString(path));
}

// Whether any box of `instance` lies over 5 cm from its first (the
// stationary tracks keep one pose).
bool Moves(const v1::Instance& instance) {
  for (const v1::Box& box : instance.boxes()) {
    double d2 = 0;
    for (int a = 0; a < 3; ++a) {
      const double d = box.center(a) - instance.boxes(0).center(a);
      d2 += d * d;
    }
    if (d2 > 0.05 * 0.05) return true;
  }
  return false;
}

// A clip sweep's points (sensor frame) taken to the world.
std::vector<Vec3> PandasetWorldPoints(const std::string& clip_dir, const v1::LidarSweep& sweep) {
  const std::string bytes = *ReadFileToString(clip_dir + "/" + sweep.points());
  std::vector<float> p(bytes.size() / sizeof(float));
  std::memcpy(p.data(), bytes.data(), p.size() * sizeof(float));
  const Rigid world_from_sensor = Rigid::FromRowMajor(sweep.world_from_sensor().data());
  std::vector<Vec3> out;
  for (size_t i = 0; i + 3 < p.size(); i += 4) {
    out.push_back(world_from_sensor * Vec3{p[i], p[i + 1], p[i + 2]});
  }
  return out;
}

class PandasetSequence : public ::testing::Test {
 protected:
  // Imports frames 46-47 once into a temporary directory.
  static void SetUpTestSuite() {
    const auto dir = testing::DataDir(kSequence);
    if (!dir) return;
    out_dir_ = new std::string(testing::MakeTempDir("pandaset_import"));
    ImportOptions options;
    options.out_dir = *out_dir_;
    PandasetOptions pandaset;
    pandaset.frames = {kFirstFrame, kEndFrame};
    pandaset.module = PicklesModule();
    auto result = ImportPandaset(*dir, options, pandaset);
    ASSERT_TRUE(result.ok()) << result.status();
    result_ = new ImportResult(*std::move(result));
    for (const v1::LidarSweep& sweep : result_->clip.lidar()) {
      (*sweeps_())[sweep.timestamp_us()] = PandasetWorldPoints(*out_dir_, sweep);
    }
  }
  static void TearDownTestSuite() {
    delete out_dir_;
    delete result_;
    out_dir_ = nullptr;
    result_ = nullptr;
    sweeps_()->clear();
  }
  // World points of each sweep, by timestamp.
  static std::map<int64_t, std::vector<Vec3>>* sweeps_() {
    static auto* sweeps = new std::map<int64_t, std::vector<Vec3>>();
    return sweeps;
  }
  // The sweep nearest in time to `t`.
  static const std::vector<Vec3>& NearestSweep(int64_t t) {
    auto best = sweeps_()->begin();
    for (auto it = sweeps_()->begin(); it != sweeps_()->end(); ++it) {
      if (std::llabs(it->first - t) < std::llabs(best->first - t)) best = it;
    }
    return best->second;
  }

  static std::string* out_dir_;
  static ImportResult* result_;
};
std::string* PandasetSequence::out_dir_ = nullptr;
ImportResult* PandasetSequence::result_ = nullptr;

TEST(PandasetFrames, ParsesHalfOpenRangesAndRejectsJunk) {
  EXPECT_EQ(ParseFrameRange("30:54")->begin, 30);
  EXPECT_EQ(ParseFrameRange("30:54")->end, 54);
  EXPECT_EQ(ParseFrameRange("40:")->begin, 40);
  EXPECT_EQ(ParseFrameRange("40:")->end, std::numeric_limits<int>::max());
  EXPECT_EQ(ParseFrameRange(":3")->begin, 0);
  for (const char* bad : {"", ":", "30", "a:b", "-1:3", "5:5", "9:3", "1:2:3"}) {
    const auto range = ParseFrameRange(bad);
    EXPECT_EQ(range.status().code(), absl::StatusCode::kInvalidArgument) << bad;
    EXPECT_NE(range.status().message().find("--frames"), absl::string_view::npos) << bad;
  }
}

TEST_F(PandasetSequence, ImportsSixCamerasTwoFramesLidarAndTracks) {
  PF_REQUIRE_DATA(dir, kSequence);
  const v1::Clip& clip = result_->clip;
  EXPECT_EQ(clip.name(), "pandaset_002");
  ASSERT_EQ(clip.cameras_size(), 6);
  ASSERT_EQ(clip.frames_size(), 12);
  ASSERT_EQ(clip.lidar_size(), 2);
  // Every track in frames 46-47, moving or stationary, each box once
  // (PandarGT twins dropped); the stationary ones at one pose.
  EXPECT_EQ(clip.instances_size(), 94);
  int boxes = 0, moving = 0;
  for (const v1::Instance& instance : clip.instances()) {
    boxes += instance.boxes_size();
    moving += Moves(instance);
  }
  EXPECT_EQ(boxes, 188);
  EXPECT_EQ(moving, 31);
  ASSERT_EQ(result_->warnings.size(), 1u);  // Where the LiDAR's head is (below).

  // front_camera: intrinsics +0.5 (integer pixel centres), timestamps to the
  // microsecond, the pose as poses.json has it, the JPEG byte for byte.
  const v1::Camera& front = clip.cameras(1);
  ASSERT_EQ(front.id(), "front_camera");
  EXPECT_EQ(front.width(), 1920);
  EXPECT_EQ(front.height(), 1080);
  EXPECT_DOUBLE_EQ(front.intrinsics().fx(), 1970.0131);
  EXPECT_DOUBLE_EQ(front.intrinsics().cx(), 970.0002 + 0.5);
  EXPECT_DOUBLE_EQ(front.intrinsics().cy(), 483.2988 + 0.5);
  const nlohmann::json poses = PandasetJson(dir + "/camera/front_camera/poses.json");
  const nlohmann::json times = PandasetJson(dir + "/camera/front_camera/timestamps.json");
  int checked = 0;
  for (const v1::Frame& f : clip.frames()) {
    if (f.camera() != "front_camera") continue;
    const int frame = kFirstFrame + checked++;
    EXPECT_EQ(f.timestamp_us(), std::llround(times[frame].get<double>() * 1e6));
    const nlohmann::json& p = poses[frame];
    const Rigid pose = Rigid::FromRowMajor(f.world_from_camera().data());
    EXPECT_NEAR(pose.translation.x, p["position"]["x"].get<double>(), 1e-12);
    const Mat3 r =
        ToMatrix(Quat{p["heading"]["w"], p["heading"]["x"], p["heading"]["y"], p["heading"]["z"]});
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) EXPECT_NEAR(pose.rotation.m[i][j], r.m[i][j], 1e-9);
    EXPECT_EQ(*ReadFileToString(*out_dir_ + "/" + f.image()),
              *ReadFileToString(dir + "/camera/front_camera/" + std::to_string(frame) + ".jpg"));
  }
  EXPECT_EQ(checked, 2);
  // Frame 46 in the first camera (back_camera) is context, 47 target (the
  // default paper policy: only the frame near 0 s is near an instant).
  EXPECT_EQ(clip.frames(0).role(), v1::Frame::CONTEXT);
}

// The sweeps are stored in the frame of the Pandar64's head (the axes of
// lidar/poses.json); taken back to the world they are the pickle's points
// (both LiDARs, every point).
TEST_F(PandasetSequence, SweepsRoundTripToThePicklesWorldPoints) {
  PF_REQUIRE_DATA(dir, kSequence);
  const std::string converted = testing::MakeTempDir("pandaset_npy");
  const auto run = testing::RunCommand(
      {"/usr/bin/python3", PicklesModule(), dir, converted, std::to_string(kFirstFrame)});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto npy = ParseNpy(*ReadFileToString(converted + "/lidar/46.npy"), "46.npy");
  ASSERT_TRUE(npy.ok()) << npy.status();
  const v1::LidarSweep& sweep = result_->clip.lidar(0);
  const nlohmann::json lidar_times = PandasetJson(dir + "/lidar/timestamps.json");
  EXPECT_EQ(sweep.timestamp_us(), std::llround(lidar_times[kFirstFrame].get<double>() * 1e6));
  const std::vector<Vec3>& world = sweeps_()->at(sweep.timestamp_us());
  ASSERT_EQ(static_cast<int64_t>(world.size()), npy->shape[0]);
  double worst = 0;
  int gt_points = 0;
  for (size_t i = 0; i < world.size(); ++i) {
    const double* row = &npy->data[i * 6];
    worst = std::max(worst, Norm(world[i] - Vec3{row[0], row[1], row[2]}));
    gt_points += row[5] == 1;
  }
  std::printf("pandaset: sweep of frame 46: %zu points (%d PandarGT), round trip error %.2g m\n",
              world.size(), gt_points, worst);
  EXPECT_LT(worst, 1e-4);  // float32 in the sensor frame.
  EXPECT_GT(gt_points, 10000);
  // The sensor frame is the Pandar64's: its points surround the origin.
  const Rigid sensor_from_world = Rigid::FromRowMajor(sweep.world_from_sensor().data()).Inverse();
  double sum_x = 0, sum_y = 0;
  for (size_t i = 0; i < world.size(); ++i) {
    if (npy->data[i * 6 + 5] != 0) continue;
    const Vec3 s = sensor_from_world * world[i];
    sum_x += s.x;
    sum_y += s.y;
  }
  EXPECT_LT(std::hypot(sum_x, sum_y) / (world.size() - gt_points), 10.0);
}

// lidar/poses.json puts the Pandar64 near the road; the sweeps start at its
// head, which its own points place 1.86 m above that pose and 0.75 m along
// its y axis (measured with the whole sequence 002 too: 0.6-0.8 m and
// 1.86 m frame by frame), above the cameras; the axes are the pose's.
TEST_F(PandasetSequence, SweepsStartAtThePandar64sHead) {
  PF_REQUIRE_DATA(dir, kSequence);
  const nlohmann::json poses = PandasetJson(dir + "/lidar/poses.json");
  const nlohmann::json& pose = poses[kFirstFrame];
  const Vec3 position{pose["position"]["x"].get<double>(), pose["position"]["y"].get<double>(),
                      pose["position"]["z"].get<double>()};
  const Quat heading =
      QuatNormalized({pose["heading"]["w"].get<double>(), pose["heading"]["x"].get<double>(),
                      pose["heading"]["y"].get<double>(), pose["heading"]["z"].get<double>()});
  const Rigid world_from_sensor =
      Rigid::FromRowMajor(result_->clip.lidar(0).world_from_sensor().data());
  const Mat3 rotation = ToMatrix(heading);
  const Vec3 head = Transpose(rotation) * (world_from_sensor.translation - position);
  std::printf("pandaset: Pandar64 head at (%.3f, %.3f, %.3f) m in the pose's frame\n", head.x,
              head.y, head.z);
  EXPECT_NEAR(head.x, 0.0, 0.1);
  EXPECT_NEAR(head.y, 0.75, 0.15);
  EXPECT_NEAR(head.z, 1.86, 0.05);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(world_from_sensor.rotation.m[r][c], rotation.m[r][c], 1e-9);
  // Above every camera of the frame (they are 1.6-1.8 m above the pose).
  for (const v1::Frame& frame : result_->clip.frames()) {
    if (frame.timestamp_us() > result_->clip.lidar(0).timestamp_us() + 50'000) continue;
    const Rigid camera = Rigid::FromRowMajor(frame.world_from_camera().data());
    EXPECT_GT(world_from_sensor.translation.z, camera.translation.z) << frame.camera();
  }
  bool said = false;
  for (const std::string& warning : result_->warnings)
    said |= warning.find("Pandar64's head") != std::string::npos;
  EXPECT_TRUE(said);
}

// A box seen by both LiDARs is one instance: no two instances have boxes at
// the same time whose centres lie inside each other's box.
TEST_F(PandasetSequence, BoxesSeenByBothLidarsAreKeptOnce) {
  PF_REQUIRE_DATA(dir, kSequence);
  const v1::Clip& clip = result_->clip;
  int overlaps = 0, pairs = 0;
  for (int a = 0; a < clip.instances_size(); ++a) {
    for (int b = a + 1; b < clip.instances_size(); ++b) {
      for (const v1::Box& ba : clip.instances(a).boxes()) {
        for (const v1::Box& bb : clip.instances(b).boxes()) {
          if (ba.timestamp_us() != bb.timestamp_us()) continue;
          ++pairs;
          overlaps += BoxContains(BoxFromProto(ba), BoxFromProto(bb).center);
        }
      }
    }
  }
  std::printf("pandaset: %d pairs of boxes of different instances at the same time, %d overlap\n",
              pairs, overlaps);
  EXPECT_GT(pairs, 500);
  EXPECT_EQ(overlaps, 0);
}

// Counts the LiDAR points inside every moving box (at its sweep), with the
// box's yaw (its angle about z) changed by `edit_yaw`; returns (points
// inside, boxes holding >= 10 points).
std::pair<int64_t, int> PointsInMovingBoxes(const v1::Clip& clip,
                                            const std::map<int64_t, std::vector<Vec3>>& sweeps,
                                            const std::function<double(double)>& edit_yaw) {
  int64_t inside = 0;
  int held = 0;
  for (const v1::Instance& instance : clip.instances()) {
    if (!Moves(instance)) continue;
    for (const v1::Box& b : instance.boxes()) {
      OrientedBox box = BoxFromProto(b);
      const double angle = std::atan2(box.rotation.m[1][0], box.rotation.m[0][0]);
      box.rotation = RotationZ(edit_yaw(angle));
      int n = 0;
      for (const Vec3& p : sweeps.at(b.timestamp_us())) n += BoxContains(box, p);
      inside += n;
      held += n >= 10;
    }
  }
  return {inside, held};
}

// The box convention (rotation Rz(yaw + 90 degrees), size (dimensions.y,
// dimensions.x, dimensions.z)) against the LiDAR: the moving boxes hold
// their points. With yaw taken as the direction of the length (Rz(yaw), the
// same size: the box turned by 90 degrees) or with yaw's sign flipped they
// hold far fewer.
TEST_F(PandasetSequence, MovingBoxesHoldTheirLidarPoints) {
  PF_REQUIRE_DATA(dir, kSequence);
  const v1::Clip& clip = result_->clip;
  int boxes = 0;
  for (const v1::Instance& instance : clip.instances()) {
    if (Moves(instance)) boxes += instance.boxes_size();
  }
  const auto [ours, held] = PointsInMovingBoxes(clip, *sweeps_(), [](double a) { return a; });
  const auto [turned, turned_held] =
      PointsInMovingBoxes(clip, *sweeps_(), [](double a) { return a - M_PI / 2; });
  const auto [flipped, flipped_held] =
      PointsInMovingBoxes(clip, *sweeps_(), [](double a) { return -(a - M_PI / 2) + M_PI / 2; });
  std::printf(
      "pandaset: %d moving boxes: %lld LiDAR points inside (%d boxes with >= 10); with "
      "Rz(yaw): %lld (%d); with Rz(-yaw + 90 degrees): %lld (%d)\n",
      boxes, static_cast<long long>(ours), held, static_cast<long long>(turned), turned_held,
      static_cast<long long>(flipped), flipped_held);
  EXPECT_GT(held, boxes / 2);
  EXPECT_LT(turned, ours * 0.6);
  EXPECT_LT(flipped, ours * 0.8);
}

// ---- LiDAR depth edges against image edges. ----

// A camera frame's image gradient magnitude (grey, central differences).
struct PandasetEdges {
  int width = 0, height = 0;
  std::vector<float> magnitude;  // [height, width]
  double mean = 0;

  // Bilinear value at continuous pixel coordinates (centres at +0.5).
  double At(double u, double v) const {
    const double x = std::clamp(u - 0.5, 0.0, width - 1.001);
    const double y = std::clamp(v - 0.5, 0.0, height - 1.001);
    const int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
    const double fx = x - x0, fy = y - y0;
    const float* r0 = &magnitude[static_cast<size_t>(y0) * width + x0];
    const float* r1 = r0 + width;
    return (r0[0] * (1 - fx) + r0[1] * fx) * (1 - fy) + (r1[0] * (1 - fx) + r1[1] * fx) * fy;
  }
};

PandasetEdges ComputeImageEdges(const std::string& path) {
  const ImageF image = *ReadImage(path, 3);
  PandasetEdges e;
  e.width = image.width;
  e.height = image.height;
  e.magnitude.assign(static_cast<size_t>(e.width) * e.height, 0.f);
  const auto grey = [&](int x, int y) {
    return (image.at(x, y, 0) + image.at(x, y, 1) + image.at(x, y, 2)) / 3.f;
  };
  double sum = 0;
  for (int y = 1; y + 1 < e.height; ++y) {
    for (int x = 1; x + 1 < e.width; ++x) {
      const float gx = (grey(x + 1, y) - grey(x - 1, y)) / 2,
                  gy = (grey(x, y + 1) - grey(x, y - 1)) / 2;
      sum += e.magnitude[static_cast<size_t>(y) * e.width + x] = std::sqrt(gx * gx + gy * gy);
    }
  }
  e.mean = sum / e.magnitude.size();
  return e;
}

// ComputeImageEdges, once per image.
const PandasetEdges& ImageEdges(const std::string& path) {
  static auto* cache = new std::map<std::string, PandasetEdges>();
  auto it = cache->find(path);
  if (it == cache->end()) it = cache->emplace(path, ComputeImageEdges(path)).first;
  return it->second;
}

// Projects `world` through the camera and returns the foreground points of
// depth edges: nearest in their pixel, with a point at least max(1 m, 15 %)
// farther within 4 pixels (the silhouette of a pole, a car, a facade).
std::vector<std::pair<double, double>> DepthEdgePoints(const std::vector<Vec3>& world,
                                                       const CameraModel& camera,
                                                       const Rigid& camera_from_world) {
  constexpr int kWindow = 4;
  const int w = camera.width(), h = camera.height();
  std::vector<float> nearest(static_cast<size_t>(w) * h, std::numeric_limits<float>::infinity());
  struct Projected {
    double u, v, z;
  };
  std::vector<Projected> projected;
  for (const Vec3& p : world) {
    const Vec3 c = camera_from_world * p;
    double u, v;
    if (c.z < 1.0 || !camera.Project(c, &u, &v)) continue;
    if (u < kWindow || v < kWindow || u >= w - kWindow - 1 || v >= h - kWindow - 1) continue;
    projected.push_back({u, v, c.z});
    float& n = nearest[static_cast<size_t>(v) * w + static_cast<size_t>(u)];
    n = std::min(n, static_cast<float>(c.z));
  }
  std::vector<std::pair<double, double>> edges;
  for (const Projected& p : projected) {
    const int x = static_cast<int>(p.u), y = static_cast<int>(p.v);
    if (p.z > nearest[static_cast<size_t>(y) * w + x] + 1e-4) continue;
    float farthest = 0;
    for (int dy = -kWindow; dy <= kWindow; ++dy) {
      for (int dx = -kWindow; dx <= kWindow; ++dx) {
        const float n = nearest[static_cast<size_t>(y + dy) * w + x + dx];
        if (std::isfinite(n)) farthest = std::max(farthest, n);
      }
    }
    if (farthest - p.z > std::max(1.0, 0.15 * p.z)) edges.push_back({p.u, p.v});
  }
  return edges;
}

// What is changed in the clip's conventions before projecting.
struct Convention {
  double pixel_offset = 0;  // Added to cx and cy (-0.5: PandaSet's cx as it is).
  bool transposed = false;  // Camera rotation transposed.
  int frame_offset = 0;     // Pose of the camera's frame this many frames later.
};

// The mean image gradient at the depth-edge points over the mean gradient of
// the image, over the clip's camera frames (a frame whose offset frame is
// not in the clip is skipped); `shifts` scans a pixel shift of the points
// per camera (dx, then dy, each with the other 0) and returns its score
// per camera and shift.
struct EdgeScore {
  double score = 0;
  int points = 0;
  std::map<std::string, std::vector<double>> scan_x, scan_y;  // Per camera, per shift.
};

EdgeScore MeasureEdges(const std::string& clip_dir, const v1::Clip& clip,
                       const std::function<const std::vector<Vec3>&(int64_t)>& sweep,
                       const Convention& convention, const std::vector<double>& shifts = {}) {
  std::map<std::string, std::vector<const v1::Frame*>> by_camera;
  for (const v1::Frame& f : clip.frames()) by_camera[f.camera()].push_back(&f);
  EdgeScore out;
  double sum = 0;
  int frames = 0;
  for (v1::Camera camera : clip.cameras()) {
    camera.mutable_intrinsics()->set_cx(camera.intrinsics().cx() + convention.pixel_offset);
    camera.mutable_intrinsics()->set_cy(camera.intrinsics().cy() + convention.pixel_offset);
    const CameraModel model = *CameraModelFromProto(camera);
    const auto& list = by_camera[camera.id()];
    for (size_t i = 0; i < list.size(); ++i) {
      const size_t posed = i + convention.frame_offset;
      if (posed >= list.size()) continue;
      Rigid world_from_camera = Rigid::FromRowMajor(list[posed]->world_from_camera().data());
      if (convention.transposed) world_from_camera.rotation = Transpose(world_from_camera.rotation);
      const auto points =
          DepthEdgePoints(sweep(list[i]->timestamp_us()), model, world_from_camera.Inverse());
      const PandasetEdges& edges = ImageEdges(clip_dir + "/" + list[i]->image());
      double at = 0;
      for (const auto& [u, v] : points) at += edges.At(u, v);
      sum += points.empty() ? 0 : at / points.size() / edges.mean;
      out.points += static_cast<int>(points.size());
      ++frames;
      for (int axis = 0; axis < 2; ++axis) {
        auto& scan = (axis == 0 ? out.scan_x : out.scan_y)[camera.id()];
        scan.resize(shifts.size(), 0.0);
        for (size_t s = 0; s < shifts.size(); ++s) {
          double shifted = 0;
          for (const auto& [u, v] : points) {
            shifted += edges.At(u + (axis == 0 ? shifts[s] : 0), v + (axis == 1 ? shifts[s] : 0));
          }
          scan[s] += shifted / points.size() / edges.mean;
        }
      }
    }
  }
  out.score = frames ? sum / frames : 0;
  return out;
}

// The position of the maximum of `values` over `shifts` (a parabola through
// the best sample and its neighbours).
double PeakShift(const std::vector<double>& shifts, const std::vector<double>& values) {
  const size_t best = std::max_element(values.begin(), values.end()) - values.begin();
  const size_t i = std::clamp<size_t>(best, 1, values.size() - 2);
  const double a = values[i - 1], b = values[i], c = values[i + 1], den = a - 2 * b + c;
  return shifts[i] + (den != 0 ? 0.5 * (a - c) / den * (shifts[1] - shifts[0]) : 0);
}

// LiDAR depth edges (silhouettes of poles, cars, facades) land on image
// edges: the image gradient there is several times the image's mean, and it
// drops when the camera rotation is transposed or the camera pose is taken
// one frame (100 ms) later. Scanning a pixel shift of the points per camera
// finds each camera's best alignment; over all cameras it is within a few
// pixels of our convention. Half a pixel (PandaSet's cx, cy used as they
// are) is below what this sample's calibration resolves: the cameras'
// best shifts spread over several pixels.
TEST_F(PandasetSequence, LidarDepthEdgesMeetImageEdges) {
  PF_REQUIRE_DATA(dir, kSequence);
  const v1::Clip& clip = result_->clip;
  const auto sweep = [](int64_t t) -> const std::vector<Vec3>& { return NearestSweep(t); };
  std::vector<double> shifts;
  for (double s = -4; s <= 4.001; s += 0.5) shifts.push_back(s);
  const EdgeScore ours = MeasureEdges(*out_dir_, clip, sweep, {}, shifts);
  const EdgeScore no_half = MeasureEdges(*out_dir_, clip, sweep, {.pixel_offset = -0.5});
  const EdgeScore transposed = MeasureEdges(*out_dir_, clip, sweep, {.transposed = true});
  // Frame 46's image with frame 47's pose: only the first frame of each
  // camera, so compare with ours on the same frames.
  const EdgeScore later = MeasureEdges(*out_dir_, clip, sweep, {.frame_offset = 1});
  v1::Clip first_frames = clip;
  first_frames.clear_frames();
  std::map<std::string, const v1::Frame*> earliest;
  for (const v1::Frame& f : clip.frames()) {
    const v1::Frame*& e = earliest[f.camera()];
    if (e == nullptr || f.timestamp_us() < e->timestamp_us()) e = &f;
  }
  for (const auto& [camera, f] : earliest) *first_frames.add_frames() = *f;
  const EdgeScore ours_first = MeasureEdges(*out_dir_, first_frames, sweep, {});
  std::printf(
      "pandaset: image gradient at %d LiDAR depth-edge points / image mean: ours %.3f, cx/cy as "
      "PandaSet's (no +0.5) %.3f, rotation transposed %.3f; frame 46 alone %.3f, with the pose "
      "100 ms later %.3f\n",
      ours.points, ours.score, no_half.score, transposed.score, ours_first.score, later.score);
  std::vector<double> all_x(shifts.size(), 0.0), all_y(shifts.size(), 0.0);
  for (const auto& [camera, scan] : ours.scan_x) {
    const std::vector<double>& scan_y = ours.scan_y.at(camera);
    std::printf("pandaset: %s best shift of the LiDAR points: dx %+.2f, dy %+.2f px\n",
                camera.c_str(), PeakShift(shifts, scan), PeakShift(shifts, scan_y));
    for (size_t s = 0; s < shifts.size(); ++s) {
      all_x[s] += scan[s];
      all_y[s] += scan_y[s];
    }
  }
  const double dx = PeakShift(shifts, all_x), dy = PeakShift(shifts, all_y);
  std::printf("pandaset: all cameras: best shift dx %+.2f, dy %+.2f px\n", dx, dy);
  EXPECT_GT(ours.score, 2.0);
  EXPECT_LT(transposed.score, ours.score * 0.6);
  EXPECT_LT(later.score, ours_first.score * 0.95);
  EXPECT_LT(std::abs(dx), 3.0);
  EXPECT_LT(std::abs(dy), 3.0);
}

TEST(PandasetImporter, HalfScaleHalvesImagesAndIntrinsics) {
  PF_REQUIRE_DATA(dir, kSequence);
  ImportOptions options;
  options.out_dir = testing::MakeTempDir("pandaset_half");
  options.cameras = {"front_camera"};
  PandasetOptions pandaset;
  pandaset.frames = {kFirstFrame, kFirstFrame + 1};
  pandaset.scale = 0.5;
  pandaset.module = PicklesModule();
  const auto result = ImportPandaset(dir, options, pandaset);
  ASSERT_TRUE(result.ok()) << result.status();
  const v1::Camera& camera = result->clip.cameras(0);
  EXPECT_EQ(camera.width(), 960);
  EXPECT_EQ(camera.height(), 540);
  EXPECT_DOUBLE_EQ(camera.intrinsics().fx(), 1970.0131 / 2);
  EXPECT_DOUBLE_EQ(camera.intrinsics().cx(), (970.0002 + 0.5) / 2);
  EXPECT_DOUBLE_EQ(camera.intrinsics().cy(), (483.2988 + 0.5) / 2);
  ASSERT_EQ(result->clip.frames_size(), 1);
  // Each output pixel is the mean of its 2x2 block (up to JPEG's error).
  const ImageF full = *ReadImage(dir + "/camera/front_camera/46.jpg", 3);
  const ImageF half = *ReadImage(options.out_dir + "/" + result->clip.frames(0).image(), 3);
  ASSERT_EQ(half.width, 960);
  ASSERT_EQ(half.height, 540);
  double error = 0;
  for (int y = 0; y < half.height; ++y) {
    for (int x = 0; x < half.width; ++x) {
      for (int c = 0; c < 3; ++c) {
        const double mean = (full.at(2 * x, 2 * y, c) + full.at(2 * x + 1, 2 * y, c) +
                             full.at(2 * x, 2 * y + 1, c) + full.at(2 * x + 1, 2 * y + 1, c)) /
                            4;
        error += std::abs(half.at(x, y, c) - mean);
      }
    }
  }
  error /= half.pixels.size();
  std::printf("pandaset: half scale: mean |half - 2x2 mean of full| = %.4f\n", error);
  EXPECT_LT(error, 2.0 / 255);
}

TEST(PandasetImporter, UnknownCameraIsNamedWithTheAvailableOnes) {
  PF_REQUIRE_DATA(dir, kSequence);
  ImportOptions options;
  options.out_dir = testing::MakeTempDir("pandaset_bad_camera");
  options.cameras = {"front"};
  PandasetOptions pandaset;
  pandaset.module = PicklesModule();
  const auto result = ImportPandaset(dir, options, pandaset);
  ASSERT_FALSE(result.ok());
  EXPECT_EQ(std::string(result.status().message()),
            "--cameras front: no such camera in the sequence (have back_camera, front_camera, "
            "front_left_camera, front_right_camera, left_camera, right_camera)");
}

TEST(PandasetImporter, MissingPythonNamesTheDebianPackages) {
  PF_REQUIRE_DATA(dir, kSequence);
  ImportOptions options;
  options.out_dir = testing::MakeTempDir("pandaset_no_python");
  options.cameras = {"front_camera"};
  PandasetOptions pandaset;
  pandaset.frames = {kFirstFrame, kFirstFrame + 1};
  pandaset.module = PicklesModule();
  pandaset.python = "/nonexistent/python3";
  const auto result = ImportPandaset(dir, options, pandaset);
  ASSERT_FALSE(result.ok());
  EXPECT_EQ(result.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_NE(result.status().message().find("apt-get install python3-pandas"),
            absl::string_view::npos)
      << result.status();
  EXPECT_FALSE(std::filesystem::exists(options.out_dir + "/clip.json"));
}

TEST(PandasetImporter, BadScaleAndEmptyRangeAreInvalid) {
  PF_REQUIRE_DATA(dir, kSequence);
  ImportOptions options;
  options.out_dir = testing::MakeTempDir("pandaset_bad");
  PandasetOptions pandaset;
  pandaset.module = PicklesModule();
  pandaset.scale = 1.5;
  EXPECT_EQ(ImportPandaset(dir, options, pandaset).status().code(),
            absl::StatusCode::kInvalidArgument);
  pandaset.scale = 1;
  pandaset.frames = {0, 10};  // The sample has frames 30-53.
  const auto none = ImportPandaset(dir, options, pandaset);
  EXPECT_EQ(none.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(none.status().message().find("no camera images"), absl::string_view::npos);
}

}  // namespace
}  // namespace pf
