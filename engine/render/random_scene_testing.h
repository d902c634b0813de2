// Scenes and cameras for the rasterizer's tests (rasterizer_test.cc and
// cuda_rasterizer_test.cc): random scenes with every kind of Gaussian, and
// the cameras they are seen through.
#ifndef POINTFORWARD_ENGINE_RENDER_RANDOM_SCENE_TESTING_H_
#define POINTFORWARD_ENGINE_RENDER_RANDOM_SCENE_TESTING_H_

#include <cstdint>

#include "common/geometry.h"
#include "engine/render/gaussian_scene.h"
#include "engine/render/rasterizer.h"

namespace pf::testing_scenes {

// A rotation by `radians` about z.
Quat YawQuat(double radians);

// A pinhole camera at the world origin looking down +z (camera = world).
RenderCamera SimpleCamera(int width = 64, int height = 64, double f = 64);

// A random scene: varied sizes (sub-pixel to larger than a tile),
// anisotropy, rotations of any norm, opacities, lifespans, and (optionally)
// two moving instances and SH colour.
struct RandomSceneSpec {
  uint32_t seed = 1;
  int count = 200;
  int channels = 5;
  bool instances = true;
  int sh_degree = -1;
  bool colour_gradients = false;  // Random gradients in [-0.5, 0.5].
};

GaussianScene RandomScene(const RandomSceneSpec& spec, const RenderCamera& camera);

// A pinhole camera of width x height pixels (f = 0.8 width), turned and moved
// away from the origin.
RenderCamera MovedCamera(int width, int height);

// MovedCamera(96, 72) as a pinhole (model 0), OpenCV (1), fisheye (2) or
// f-theta (3) camera; kCameraModels of them.
inline constexpr int kCameraModels = 4;
RenderCamera MovedCameraOfModel(int model);

// A trajectory edit that moves RandomScene's "actor1" 0.4 m along x and
// 0.1 m along y.
ActorEdit MoveSecondActor(const GaussianScene& scene);

}  // namespace pf::testing_scenes

#endif  // POINTFORWARD_ENGINE_RENDER_RANDOM_SCENE_TESTING_H_
