// Random and simple scenes for the rasterizer tests (CPU and CUDA).
#include "engine/render/random_scene_testing.h"

#include <cmath>
#include <limits>
#include <random>
#include <string>

namespace pf::testing_scenes {

constexpr float kInf = std::numeric_limits<float>::infinity();

Quat YawQuat(double radians) { return {std::cos(radians / 2), 0, 0, std::sin(radians / 2)}; }

RenderCamera SimpleCamera(int width, int height, double f) {
  RenderCamera camera;
  camera.model = CameraModel(width, height, f, f, width / 2.0, height / 2.0);
  return camera;
}

GaussianScene RandomScene(const RandomSceneSpec& spec, const RenderCamera& camera) {
  std::mt19937 rng(spec.seed);
  auto uniform = [&](double lo, double hi) {
    return std::uniform_real_distribution<double>(lo, hi)(rng);
  };
  GaussianScene scene;
  scene.num_channels = spec.channels;
  scene.sh_degree = spec.sh_degree;
  scene.time_origin_us = 1'000'000;
  if (spec.instances) {
    for (int k = 0; k < 2; ++k) {
      InstanceTrack track;
      track.id = "actor" + std::to_string(k);
      for (int b = 0; b < 3; ++b) {
        TrackBox box;
        box.timestamp_us = scene.time_origin_us + b * 1'000'000;
        box.center = {uniform(-0.5, 0.5), uniform(-0.3, 0.3), uniform(4, 6)};
        box.rotation = YawQuat(uniform(-0.4, 0.4));
        box.size = {2, 1, 1};
        track.boxes.push_back(box);
      }
      scene.instances.push_back(track);
    }
  }
  const CameraModel& m = camera.model;
  const double half_x = 0.6 * m.width() / m.fx(), half_y = 0.6 * m.height() / m.fy();
  for (int i = 0; i < spec.count; ++i) {
    const double z = uniform(0, 1) < 0.03 ? uniform(-1, 0.005) : uniform(1.5, 8);
    const Vec3 p_cam{uniform(-half_x, half_x) * std::abs(z), uniform(-half_y, half_y) * std::abs(z),
                     z};
    const Vec3 p_world = camera.world_from_camera * p_cam;
    const size_t g = scene.size();
    scene.Resize(g + 1);
    uint32_t owner = 0;
    if (spec.instances && uniform(0, 1) < 0.25) owner = uniform(0, 1) < 0.5 ? 1 : 2;
    Vec3 mean = p_world;
    if (owner > 0) {
      // Canonical frame = world at the first box: keep the point as is.
      mean = p_world;
    }
    for (int c = 0; c < 3; ++c) scene.means[3 * g + c] = static_cast<float>(mean[c]);
    // Size from 0.2 to about 40 pixels at this depth, anisotropic.
    const double pixel_size = std::abs(z) / m.fx();
    const double base = pixel_size * std::exp(uniform(std::log(0.2), std::log(40.0)));
    for (int c = 0; c < 3; ++c) {
      scene.log_scales[3 * g + c] = static_cast<float>(std::log(base) + uniform(-2.5, 0));
    }
    const double norm = uniform(0.5, 2);
    Quat q = QuatNormalized({uniform(-1, 1), uniform(-1, 1), uniform(-1, 1), uniform(-1, 1)});
    scene.rotations[4 * g] = static_cast<float>(q.w * norm);
    scene.rotations[4 * g + 1] = static_cast<float>(q.x * norm);
    scene.rotations[4 * g + 2] = static_cast<float>(q.y * norm);
    scene.rotations[4 * g + 3] = static_cast<float>(q.z * norm);
    scene.opacity_logits[g] = static_cast<float>(uniform(-4, 5));
    for (int c = 0; c < spec.channels; ++c) {
      scene.features[g * spec.channels + c] = static_cast<float>(uniform(0, 1));
    }
    for (int c = 0; c < 3 * scene.sh_coeffs(); ++c) {
      scene.sh[g * 3 * scene.sh_coeffs() + c] = static_cast<float>(uniform(-0.5, 0.5));
    }
    scene.times[g] = static_cast<float>(uniform(0, 2));
    scene.lifespans[g] = uniform(0, 1) < 0.5 ? kInf : static_cast<float>(uniform(0, 1));
    scene.owners[g] = owner;
  }
  if (spec.colour_gradients) {
    scene.colour_gradients.resize(6 * scene.size());
    for (float& g : scene.colour_gradients) g = static_cast<float>(uniform(-0.5, 0.5));
  }
  return scene;
}

RenderCamera MovedCamera(int width, int height) {
  RenderCamera camera = SimpleCamera(width, height, 0.8 * width);
  camera.world_from_camera.rotation = ToMatrix(QuatNormalized({0.98, 0.05, -0.1, 0.08}));
  camera.world_from_camera.translation = {0.3, -0.2, 0.5};
  return camera;
}

RenderCamera MovedCameraOfModel(int model) {
  RenderCamera camera = MovedCamera(96, 72);
  if (model == 1) camera.model.SetOpenCv(-0.25, 0.08, 0.002, -0.001, 0.0);
  if (model == 2) camera.model.SetFisheye(0.05, -0.01, 0.002, 0.0);
  if (model == 3) camera.model.SetFTheta({0, 76.8, 0, -3.84, 0, 0.2});
  return camera;
}

ActorEdit MoveSecondActor(const GaussianScene& scene) {
  ActorEdit move;
  move.kind = ActorEdit::Kind::kTrajectory;
  move.instance_id = "actor1";
  move.boxes = scene.instances[1].boxes;
  for (TrackBox& box : move.boxes) box.center = box.center + Vec3{0.4, 0.1, 0};
  return move;
}

}  // namespace pf::testing_scenes
