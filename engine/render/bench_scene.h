// A reproducible street-like Gaussian scene for the rasterizer benchmark.
//
// The layout imitates a reconstructed driving scene seen from a car camera:
// a 160 m street (road and sidewalk splats lying flat), building facades on
// both sides (flattened splats facing the street), poles, tree crowns, parked
// and driving cars (instances with box tracks, their splats on the box
// surfaces) and a few large far sky splats. Splat sizes follow the local
// density (so 1M Gaussians make a finer, not a denser-looking, scene) with
// anisotropic, flattened shapes and varied opacities. The same arguments
// always give the same scene.
#ifndef POINTFORWARD_ENGINE_RENDER_BENCH_SCENE_H_
#define POINTFORWARD_ENGINE_RENDER_BENCH_SCENE_H_

#include <cstdint>
#include <string>

#include "engine/render/gaussian_scene.h"
#include "engine/render/rasterizer.h"

namespace pf {

struct BenchScene {
  GaussianScene scene;
  RenderCamera camera;       // A forward car camera at 1.6 m.
  int64_t timestamp_us = 0;  // The time to render at (cars mid-track).
  std::string description;   // A JSON object describing the layout.
};

// Builds a street scene of exactly `num_gaussians` Gaussians with `channels`
// feature channels (the first three are colour) and a camera of
// `width` x `height` pixels, from `seed`.
BenchScene MakeBenchScene(int64_t num_gaussians, int width, int height, int channels,
                          uint64_t seed);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RENDER_BENCH_SCENE_H_
