// Tests of the Waymo importer on the real one-frame segment: what lands in
// the clip, and the calibration conventions proved by projecting every
// laser_labels box through our clip's cameras onto the frame's own
// projected_lidar_labels.
#include "engine/importers/waymo_importer.h"

#include <gtest/gtest.h>
#include <zlib.h>

#include <cstdio>
#include <cstring>
#include <fstream>
#include <functional>
#include <map>

#include "common/file_util.h"
#include "engine/camera/camera_model.h"
#include "engine/importers/box_geometry.h"
#include "engine/importers/box_test_util.h"
#include "engine/importers/crc32c.h"
#include "engine/importers/tfrecord_reader.h"
#include "tests/test_util.h"

namespace pf {
namespace {

namespace v1 = pointforward::v1;
using testing::BoxFromProto;
namespace waymo = pointforward::waymo;

constexpr char kSegment[] = "pvps_data_one_frame.tfrecord";

waymo::Frame ReadFrame(const std::string& path) {
  auto reader = TfRecordReader::Open(path);
  EXPECT_TRUE(reader.ok()) << reader.status();
  std::string record;
  EXPECT_TRUE(*(*reader)->Next(&record));
  waymo::Frame frame;
  EXPECT_TRUE(frame.ParseFromString(record));
  return frame;
}

TEST(WaymoImporter, OpenCvToWaymoAxes) {
  const Mat3 r = OpenCvToWaymoCamera();
  const Vec3 forward = r * Vec3{0, 0, 1}, right = r * Vec3{1, 0, 0}, down = r * Vec3{0, 1, 0};
  EXPECT_EQ(forward.x, 1);  // OpenCV z = Waymo x (forward).
  EXPECT_EQ(right.y, -1);   // OpenCV x = Waymo -y (left is +y).
  EXPECT_EQ(down.z, -1);    // OpenCV y = Waymo -z (up is +z).
  EXPECT_NEAR(Determinant(r), 1.0, 1e-12);
}

TEST(WaymoImporter, ImportsFiveCamerasOneFrameAndLabels) {
  PF_REQUIRE_DATA(dir, "waymo_one_frame");
  const std::string out = testing::MakeTempDir("waymo_import");
  ImportOptions options;
  options.out_dir = out;
  auto result = ImportWaymo(dir + "/" + kSegment, options);
  ASSERT_TRUE(result.ok()) << result.status();
  const v1::Clip& clip = result->clip;
  const waymo::Frame frame = ReadFrame(dir + "/" + kSegment);

  EXPECT_EQ(clip.name(), "1024360143612057520_3580_000_3600_000");
  ASSERT_EQ(clip.cameras_size(), 5);
  ASSERT_EQ(clip.frames_size(), 5);
  EXPECT_EQ(clip.instances_size(), 75);
  EXPECT_EQ(clip.lidar_size(), 0);
  EXPECT_TRUE(result->warnings.empty());
  EXPECT_EQ(result->manifest_path, out + "/clip.json");

  std::map<std::string, v1::Camera> cameras;
  for (const auto& c : clip.cameras()) cameras[c.id()] = c;
  const v1::Camera& front = cameras.at("FRONT");
  EXPECT_EQ(front.width(), 1920);
  EXPECT_EQ(front.height(), 1280);
  EXPECT_DOUBLE_EQ(front.intrinsics().fx(), 2044.5083584358413);
  EXPECT_DOUBLE_EQ(front.intrinsics().cx(), 949.57464513520711);  // No +0.5 (see header).
  EXPECT_EQ(front.distortion().model(), v1::Distortion::OPENCV);
  EXPECT_DOUBLE_EQ(front.distortion().k2(), -0.33001662226602974);
  EXPECT_EQ(cameras.at("SIDE_LEFT").height(), 886);

  for (const v1::Frame& f : clip.frames()) {
    EXPECT_EQ(f.role(), v1::Frame::CONTEXT);  // One frame per camera.
    // The JPEG is written byte for byte.
    const auto written = ReadFileToString(out + "/" + f.image());
    ASSERT_TRUE(written.ok()) << written.status();
    bool matched = false;
    for (const auto& image : frame.images()) {
      if (waymo::CameraName::Name_Name(image.name()) != f.camera()) continue;
      EXPECT_EQ(*written, image.image());
      matched = true;
      // The cameras are read line by line: the frame is at its first line's
      // time and pose, the last line readoutUs later at the pose the
      // image's velocity gives (docs/IMPORTERS.md, "Waymo").
      const waymo::CameraCalibration* calibration = nullptr;
      for (const auto& c : frame.context().camera_calibrations()) {
        if (c.name() == image.name()) calibration = &c;
      }
      ASSERT_NE(calibration, nullptr);
      ASSERT_TRUE(image.has_velocity());
      ASSERT_TRUE(f.has_rolling_shutter()) << f.camera();
      const v1::RollingShutter& shutter = f.rolling_shutter();
      EXPECT_EQ(v1::RollingShutter::Readout_Name(shutter.readout()),
                waymo::CameraCalibration::RollingShutterReadOutDirection_Name(
                    calibration->rolling_shutter_direction()));
      const double first = image.camera_trigger_time() + 0.5 * image.shutter();
      const double last = image.camera_readout_done_time() - 0.5 * image.shutter();
      EXPECT_NEAR(f.timestamp_us(), first * 1e6, 1.0);
      EXPECT_NEAR(shutter.readout_us(), (last - first) * 1e6, 1.0);
      EXPECT_GT(shutter.readout_us(), 1000);
      EXPECT_LT(shutter.readout_us(), 100000);
      // The camera centre moves by the velocity over the readout.
      const Vec3 v{image.velocity().v_x(), image.velocity().v_y(), image.velocity().v_z()};
      const Vec3 start{f.world_from_camera(3), f.world_from_camera(7), f.world_from_camera(11)};
      const Vec3 end{shutter.world_from_camera_end(3), shutter.world_from_camera_end(7),
                     shutter.world_from_camera_end(11)};
      const Vec3 travel = end - start;
      const Vec3 expected = (last - first) * v;
      EXPECT_NEAR(Norm(travel - expected), 0.0, 0.02 * Norm(expected) + 1e-3)
          << f.camera() << " travel " << Norm(travel) << " m";
      // The image's own pose lies on the way, at its pose_timestamp.
      auto pose = WaymoWorldFromCamera(frame, image, *calibration);
      ASSERT_TRUE(pose.ok());
      const double s = (image.pose_timestamp() - first) / (last - first);
      EXPECT_LT(Norm(start + s * travel - pose->translation), 1e-3 + 0.02 * Norm(expected));
    }
    EXPECT_TRUE(matched) << f.camera();
  }

  // Every box of the frame, in world coordinates at the frame's timestamp.
  for (const auto& instance : clip.instances()) {
    ASSERT_EQ(instance.boxes_size(), 1);
    EXPECT_EQ(instance.boxes(0).timestamp_us(), frame.timestamp_micros());
  }
}

TEST(WaymoImporter, FrontCameraLooksAlongTheVehicleForwardAxis) {
  PF_REQUIRE_DATA(dir, "waymo_one_frame");
  const waymo::Frame frame = ReadFrame(dir + "/" + kSegment);
  const auto& cal = frame.context().camera_calibrations(0);
  ASSERT_EQ(cal.name(), waymo::CameraName::FRONT);
  auto world_from_camera = WaymoWorldFromCamera(frame, frame.images(0), cal);
  ASSERT_TRUE(world_from_camera.ok()) << world_from_camera.status();
  auto world_from_vehicle = RigidFromWaymoTransform(frame.pose(), "pose");
  ASSERT_TRUE(world_from_vehicle.ok());
  const Mat3 vehicle_from_camera =
      Transpose(world_from_vehicle->rotation) * world_from_camera->rotation;
  // OpenCV z (optical axis) ~ vehicle +x, OpenCV y (down) ~ vehicle -z.
  EXPECT_GT(vehicle_from_camera.Col(2).x, 0.99);
  EXPECT_LT(vehicle_from_camera.Col(1).z, -0.99);
  EXPECT_LT(vehicle_from_camera.Col(0).y, -0.99);  // Right = -left.
}

struct IouFigures {
  int count = 0, in_view = 0;
  double mean = 0, mean_in_view = 0;
};

// Projects every laser_labels box of `clip` through its cameras (after
// `edit` changes them) and compares with the frame's projected_lidar_labels.
IouFigures MeasureIou(const v1::Clip& clip, const waymo::Frame& frame,
                      const std::function<void(v1::Camera*)>& edit, bool print) {
  std::map<std::string, const v1::Instance*> instances;
  for (const auto& instance : clip.instances()) instances[instance.id()] = &instance;
  IouFigures figures;
  for (const waymo::CameraLabels& labels : frame.projected_lidar_labels()) {
    const std::string camera = waymo::CameraName::Name_Name(labels.name());
    v1::Camera cam;
    const v1::Frame* image = nullptr;
    for (const auto& c : clip.cameras()) {
      if (c.id() == camera) cam = c;
    }
    for (const auto& f : clip.frames()) {
      if (f.camera() == camera) image = &f;
    }
    EXPECT_EQ(cam.id(), camera);
    EXPECT_NE(image, nullptr) << camera;
    if (image == nullptr) continue;
    edit(&cam);
    auto model = CameraModelFromProto(cam);
    EXPECT_TRUE(model.ok()) << model.status();
    // A rolling-shutter frame: the pose of its middle line.
    Rigid world_from_camera = Rigid::FromRowMajor(image->world_from_camera().data());
    if (image->has_rolling_shutter()) {
      world_from_camera = InterpolateRigid(
          world_from_camera,
          Rigid::FromRowMajor(image->rolling_shutter().world_from_camera_end().data()), 0.5);
    }
    const Rigid camera_from_world = world_from_camera.Inverse();
    double camera_sum = 0;
    int camera_count = 0;
    for (const waymo::Label& label : labels.labels()) {
      const std::string suffix = "_" + camera;
      const std::string laser_id = label.id().substr(0, label.id().size() - suffix.size());
      EXPECT_EQ(instances.count(laser_id), 1u) << label.id();
      if (!instances.count(laser_id)) continue;
      const auto footprint =
          ProjectBox(BoxFromProto(instances[laser_id]->boxes(0)), *model, camera_from_world);
      if (!footprint) continue;  // A corner behind the camera: Waymo clips in 3D.
      const auto& b = label.box();
      const PixelRect theirs{b.center_x() - b.length() / 2, b.center_y() - b.width() / 2,
                             b.center_x() + b.length() / 2, b.center_y() + b.width() / 2};
      const double iou = Iou(ClipRect(footprint->rect, cam.width(), cam.height()), theirs);
      camera_sum += iou;
      ++camera_count;
      if (footprint->fully_in_view) {
        figures.mean_in_view += iou;
        ++figures.in_view;
      }
    }
    if (print) {
      std::printf("waymo %s: %d labels, mean IoU %.4f\n", camera.c_str(), camera_count,
                  camera_count ? camera_sum / camera_count : 0.0);
    }
    figures.mean += camera_sum;
    figures.count += camera_count;
  }
  if (figures.count) figures.mean /= figures.count;
  if (figures.in_view) figures.mean_in_view /= figures.in_view;
  return figures;
}

TEST(WaymoImporter, LaserLabelsProjectOntoProjectedLidarLabels) {
  PF_REQUIRE_DATA(dir, "waymo_one_frame");
  ImportOptions options;
  options.out_dir = testing::MakeTempDir("waymo_iou");
  auto result = ImportWaymo(dir + "/" + kSegment, options);
  ASSERT_TRUE(result.ok()) << result.status();
  const waymo::Frame frame = ReadFrame(dir + "/" + kSegment);
  const IouFigures f = MeasureIou(
      result->clip, frame, [](v1::Camera*) {}, true);
  std::printf("waymo overall: %d labels, mean IoU %.4f; fully in view: %d, mean IoU %.4f\n",
              f.count, f.mean, f.in_view, f.mean_in_view);
  RecordProperty("mean_iou", std::to_string(f.mean));
  RecordProperty("mean_iou_fully_in_view", std::to_string(f.mean_in_view));
  ASSERT_GT(f.count, 30);
  ASSERT_GT(f.in_view, 10);
  EXPECT_GE(f.mean, 0.7);
  EXPECT_GE(f.mean_in_view, 0.7);
}

// The same comparison with a convention broken: the figures must drop, so
// the test above would catch that mistake.
TEST(WaymoImporter, BrokenConventionsLowerTheIou) {
  PF_REQUIRE_DATA(dir, "waymo_one_frame");
  ImportOptions options;
  options.out_dir = testing::MakeTempDir("waymo_iou_broken");
  auto result = ImportWaymo(dir + "/" + kSegment, options);
  ASSERT_TRUE(result.ok()) << result.status();
  const waymo::Frame frame = ReadFrame(dir + "/" + kSegment);
  const double good = MeasureIou(
                          result->clip, frame, [](v1::Camera*) {}, false)
                          .mean;
  const double no_distortion =
      MeasureIou(
          result->clip, frame,
          [](v1::Camera* c) { c->mutable_distortion()->set_model(v1::Distortion::NONE); }, false)
          .mean;
  const double flipped_distortion = MeasureIou(
                                        result->clip, frame,
                                        [](v1::Camera* c) {
                                          c->mutable_distortion()->set_k1(-c->distortion().k1());
                                          c->mutable_distortion()->set_k2(-c->distortion().k2());
                                        },
                                        false)
                                        .mean;
  const double half_pixel = MeasureIou(
                                result->clip, frame,
                                [](v1::Camera* c) {
                                  c->mutable_intrinsics()->set_cx(c->intrinsics().cx() + 0.5);
                                  c->mutable_intrinsics()->set_cy(c->intrinsics().cy() + 0.5);
                                },
                                false)
                                .mean;
  const double swapped_focal =
      MeasureIou(
          result->clip, frame,
          [](v1::Camera* c) {
            c->mutable_intrinsics()->set_cx(c->height() - c->intrinsics().cy());
          },
          false)
          .mean;
  std::printf(
      "waymo mean IoU: ours %.4f, no distortion %.4f, distortion sign flipped %.4f, "
      "cx/cy +0.5 %.4f, wrong cx %.4f\n",
      good, no_distortion, flipped_distortion, half_pixel, swapped_focal);
  EXPECT_LT(no_distortion, good - 0.01);
  EXPECT_LT(flipped_distortion, good - 0.03);
  EXPECT_LT(swapped_focal, 0.7);
  EXPECT_LE(half_pixel, good + 1e-3);  // +0.5 is no better: Waymo's pixel 0 is an edge.
}

TEST(WaymoImporter, CameraSubsetAndUnknownCamera) {
  PF_REQUIRE_DATA(dir, "waymo_one_frame");
  ImportOptions options;
  options.out_dir = testing::MakeTempDir("waymo_subset");
  options.cameras = {"FRONT", "SIDE_RIGHT"};
  auto result = ImportWaymo(dir + "/" + kSegment, options);
  ASSERT_TRUE(result.ok()) << result.status();
  ASSERT_EQ(result->clip.cameras_size(), 2);
  EXPECT_EQ(result->clip.frames_size(), 2);

  options.cameras = {"FRNT"};
  const auto bad = ImportWaymo(dir + "/" + kSegment, options);
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(std::string(bad.status().message()),
            "--cameras FRNT: no such camera in the segment (have FRONT, FRONT_LEFT, "
            "FRONT_RIGHT, SIDE_LEFT, SIDE_RIGHT)");
}

TEST(WaymoImporter, EmptyTimeWindowIsAnError) {
  PF_REQUIRE_DATA(dir, "waymo_one_frame");
  ImportOptions options;
  options.out_dir = testing::MakeTempDir("waymo_window");
  options.start_us = 5'000'000;
  options.duration_us = 1'000'000;
  const auto result = ImportWaymo(dir + "/" + kSegment, options);
  ASSERT_FALSE(result.ok());
  EXPECT_NE(
      std::string(result.status().message()).find("no camera images in the selected time window"),
      std::string::npos)
      << result.status();
}

TEST(WaymoImporter, CorruptedSegmentIsRejectedWithOffset) {
  PF_REQUIRE_DATA(dir, "waymo_one_frame");
  std::string bytes = *ReadFileToString(dir + "/" + kSegment);
  bytes[123456] ^= 0x01;
  const std::string tmp = testing::MakeTempDir("waymo_corrupt");
  const std::string path = tmp + "/flipped.tfrecord";
  std::ofstream(path, std::ios::binary) << bytes;
  ImportOptions options;
  options.out_dir = tmp + "/out";
  const auto result = ImportWaymo(path, options);
  ASSERT_FALSE(result.ok());
  EXPECT_EQ(result.status().code(), absl::StatusCode::kDataLoss);
  EXPECT_NE(std::string(result.status().message()).find("record 0 at byte offset 0: corrupt"),
            std::string::npos)
      << result.status();
}

TEST(WaymoImporter, FramesWithRangeImagesGiveOneSweepPerFrame) {
  PF_REQUIRE_DATA(dir, "waymo_one_frame");
  // The sample has no returns: add a 1 x 2 TOP range image to a copy of it.
  waymo::Frame frame = ReadFrame(dir + "/" + kSegment);
  waymo::MatrixFloat image;
  for (float v : {20.0f, 0.5f, 0.0f, 0.0f, 30.0f, 0.75f, 0.0f, 0.0f}) image.add_data(v);
  for (int d : {1, 2, 4}) image.mutable_shape()->add_dims(d);
  const std::string raw = image.SerializeAsString();
  uLongf size = compressBound(raw.size());
  std::string compressed(size, '\0');
  compress(reinterpret_cast<Bytef*>(compressed.data()), &size,
           reinterpret_cast<const Bytef*>(raw.data()), raw.size());
  compressed.resize(size);
  waymo::Laser* laser = frame.add_lasers();
  laser->set_name(waymo::LaserName::TOP);
  laser->mutable_ri_return1()->set_range_image_compressed(compressed);
  auto* cal = frame.mutable_context()->mutable_laser_calibrations();
  for (auto& c : *cal) {
    if (c.name() == waymo::LaserName::TOP) {
      c.clear_beam_inclinations();  // One row: the uniform rule.
    }
  }
  std::string payload;
  ASSERT_TRUE(frame.SerializeToString(&payload));
  auto le = [](uint64_t v, int n) {
    std::string s;
    for (int i = 0; i < n; ++i) s.push_back(static_cast<char>((v >> (8 * i)) & 0xFF));
    return s;
  };
  const std::string length = le(payload.size(), 8);
  const std::string tmp = testing::MakeTempDir("waymo_lidar");
  std::ofstream(tmp + "/lidar.tfrecord", std::ios::binary)
      << length << le(MaskCrc32c(Crc32c(length)), 4) << payload
      << le(MaskCrc32c(Crc32c(payload)), 4);
  ImportOptions options;
  options.out_dir = tmp + "/out";
  const auto result = ImportWaymo(tmp + "/lidar.tfrecord", options);
  ASSERT_TRUE(result.ok()) << result.status();
  EXPECT_TRUE(result->warnings.empty());
  ASSERT_EQ(result->clip.lidar_size(), 1);
  const v1::LidarSweep& sweep = result->clip.lidar(0);
  EXPECT_EQ(sweep.timestamp_us(), frame.timestamp_micros());
  EXPECT_EQ(sweep.points(), "lidar/LIDAR_1553735853462203.bin");
  EXPECT_EQ(sweep.world_from_sensor(3), frame.pose().transform(3));  // The frame pose.
  const auto bytes = ReadFileToString(options.out_dir + "/" + sweep.points());
  ASSERT_TRUE(bytes.ok());
  ASSERT_EQ(bytes->size(), 2 * 4 * sizeof(float));
  float p[8];
  std::memcpy(p, bytes->data(), sizeof(p));
  // Ranges 20 m and 30 m from the TOP laser (1.43 m ahead, 2.184 m up).
  EXPECT_NEAR(Norm(Vec3{p[0] - 1.43, p[1], p[2] - 2.184}), 20.0, 1e-3);
  EXPECT_NEAR(Norm(Vec3{p[4] - 1.43, p[5], p[6] - 2.184}), 30.0, 1e-3);
  EXPECT_FLOAT_EQ(p[7], 0.75f);
}

}  // namespace
}  // namespace pf
