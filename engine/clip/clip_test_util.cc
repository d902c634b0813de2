// Test helpers for clip manifests.
#include "engine/clip/clip_test_util.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "absl/strings/str_cat.h"
#include "common/file_util.h"
#include "common/geometry.h"
#include "engine/clip/clip_io.h"
#include "engine/image/image_io.h"

namespace pf::testing {
namespace {

using pointforward::v1::Clip;
using pointforward::v1::Distortion;
using pointforward::v1::Frame;

void CheckOk(const absl::Status& status) {
  if (!status.ok()) {
    std::fprintf(stderr, "clip_test_util: %s\n", std::string(status.message()).c_str());
    std::abort();
  }
}

// Appends the 16 numbers of `pose`.
template <typename Repeated>
void AddPose(const Rigid& pose, Repeated* out) {
  for (double v : pose.ToRowMajor()) out->Add(v);
}

// A yaw of `degrees` about the world z axis, then a shift along x.
Rigid TestPose(double degrees, double x) {
  const double a = degrees * M_PI / 180.0;
  Rigid pose;
  pose.rotation = ToMatrix(Quat{std::cos(a / 2), 0, 0, std::sin(a / 2)});
  pose.translation = {x, 0, 1.5};
  return pose;
}

}  // namespace

void WriteTestImage(const std::string& path, int width, int height) {
  ImageF image(width, height, 3);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      image.at(x, y, 0) = float(x) / width;
      image.at(x, y, 1) = float(y) / height;
      image.at(x, y, 2) = (x + y) % 2;
    }
  }
  CheckOk(WritePng(path, image));
}

void WriteTestDepth(const std::string& path, int width, int height) {
  ImageF depth(width, height, 1);
  for (float& d : depth.pixels) d = 10.f;
  CheckOk(WriteDepthExr(path, depth));
}

Clip MakeTestClip(const std::string& dir) {
  CheckOk(MakeDirs(dir + "/images"));
  CheckOk(MakeDirs(dir + "/depth"));
  CheckOk(MakeDirs(dir + "/lidar"));
  Clip clip;
  clip.set_name("test clip");
  for (const char* id : {"front", "left"}) {
    auto* camera = clip.add_cameras();
    camera->set_id(id);
    camera->set_width(kTestWidth);
    camera->set_height(kTestHeight);
    camera->mutable_intrinsics()->set_fx(30);
    camera->mutable_intrinsics()->set_fy(30);
    camera->mutable_intrinsics()->set_cx(kTestWidth / 2.0);
    camera->mutable_intrinsics()->set_cy(kTestHeight / 2.0);
  }
  clip.mutable_cameras(1)->mutable_distortion()->set_model(Distortion::OPENCV);
  clip.mutable_cameras(1)->mutable_distortion()->set_k1(-0.1);

  for (int t = 0; t < kTestTimestamps; ++t) {
    const int64_t timestamp_us = int64_t{t} * 100000;
    for (const char* id : {"front", "left"}) {
      const bool front = std::string(id) == "front";
      Frame* frame = clip.add_frames();
      frame->set_camera(id);
      frame->set_timestamp_us(timestamp_us);
      frame->set_image(absl::StrCat("images/", id, "_", t, ".png"));
      WriteTestImage(absl::StrCat(dir, "/", frame->image()), kTestWidth, kTestHeight);
      AddPose(TestPose(front ? 0 : 45, t * 1.0), frame->mutable_world_from_camera());
      if (front) {
        frame->set_depth(absl::StrCat("depth/front_", t, ".exr"));
        WriteTestDepth(absl::StrCat(dir, "/", frame->depth()), kTestWidth, kTestHeight);
      }
      if (t == 0) {
        frame->set_role(front ? Frame::CONTEXT : Frame::ROLE_UNSPECIFIED);
      } else {
        frame->set_role(Frame::TARGET);
      }
    }
  }

  for (int t = 0; t < 2; ++t) {
    auto* sweep = clip.add_lidar();
    sweep->set_timestamp_us(int64_t{t} * 100000);
    sweep->set_points(absl::StrCat("lidar/", t, ".bin"));
    std::string bytes;
    for (int i = 0; i < kTestLidarPoints; ++i) {
      const float record[4] = {float(i), float(-i), 0.5f, 0.25f};
      bytes.append(reinterpret_cast<const char*>(record), sizeof(record));
    }
    CheckOk(WriteFileAtomic(absl::StrCat(dir, "/", sweep->points()), bytes));
    AddPose(TestPose(0, t * 1.0), sweep->mutable_world_from_sensor());
  }

  auto* instance = clip.add_instances();
  instance->set_id("car-1");
  instance->set_category("car");
  for (int t = 0; t < kTestTimestamps; ++t) {
    auto* box = instance->add_boxes();
    box->set_timestamp_us(int64_t{t} * 100000);
    for (double v : {10.0 + t, 2.0, 0.8}) box->add_center(v);
    for (double v : {4.5, 1.9, 1.6}) box->add_size(v);
    const double a = 0.1 * t;  // Slowly turning.
    for (double v : {std::cos(a / 2), 0.0, 0.0, std::sin(a / 2)}) box->add_rotation(v);
  }
  return clip;
}

std::string WriteTestClip(const std::string& dir, const Clip& clip) {
  const std::string path = dir + "/clip.json";
  CheckOk(SaveClip(clip, path));
  return path;
}

}  // namespace pf::testing
