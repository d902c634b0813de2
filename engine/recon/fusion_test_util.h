// Inputs shared by the fusion tests (fusion_test.cc, tensor_fusion_test.cc)
// and pf_fusion_bench (fusion_bench.cc).
#ifndef POINTFORWARD_ENGINE_RECON_FUSION_TEST_UTIL_H_
#define POINTFORWARD_ENGINE_RECON_FUSION_TEST_UTIL_H_

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "engine/recon/fusion.h"
#include "engine/recon/query_set.h"

namespace pf::testing {

// Returns one query at (0, 0, 10), red, seen by view 0 from the origin along
// +z at pixel (8, 6) of a 16 x 12 image (fx = fy = 10, centre (8, 6)).
inline QuerySet OneQueryTenMetresAhead(uint32_t owner = 0) {
  QuerySet q;
  q.positions = {0, 0, 10};
  q.rgb = {1, 0, 0};
  q.plucker = {0, 0, 1, 0, 0, 0};
  q.normals = {0, 0, -1};
  q.rays = {0, 0, 1};
  q.depths = {10};
  q.footprints = {1};
  q.views = {0};
  q.pixels = {6 * 16 + 8};
  q.owners = {owner};
  q.far = {0};
  return q;
}

// Returns `per_view` queries lifted from random pixels of each of `views`
// (anything with a ContextView `view` and a ViewDepth `depth`): ego pixels
// skipped, a tenth on the far layer at 500 m, a fifth of the rest pushed 20 %
// nearer than the surface, a tenth of those on instance 1 (owner 1); random
// colours, the given footprint.
template <typename View>
QuerySet RandomQueries(const std::vector<View>& views, int per_view, std::mt19937& random,
                       float footprint = 0.1f) {
  std::uniform_real_distribution<float> unit(0.f, 1.f);
  QuerySet q;
  for (size_t v = 0; v < views.size(); ++v) {
    const ContextView& view = views[v].view;
    const ViewDepth& depth = views[v].depth;
    const int w = view.width(), h = view.height();
    for (int i = 0; i < per_view; ++i) {
      const int x = std::min(w - 1, static_cast<int>(unit(random) * w));
      const int y = std::min(h - 1, static_cast<int>(unit(random) * h));
      const size_t j = static_cast<size_t>(y) * w + x;
      if (view.is_ego(j)) continue;  // Never lifted.
      Vec3 ray;
      if (!view.camera.Unproject(x + 0.5, y + 0.5, &ray)) continue;
      const bool far = unit(random) < 0.1f;
      const float z = far ? 500.f : depth.depth[j] * (unit(random) < 0.2f ? 0.8f : 1.f);
      const Vec3 world = view.world_from_camera * Vec3{ray.x * z, ray.y * z, z};
      const uint32_t owner = !far && unit(random) < 0.1f ? 1 : 0;
      q.positions.insert(q.positions.end(), {float(world.x), float(world.y), float(world.z)});
      q.rgb.insert(q.rgb.end(), {unit(random), unit(random), unit(random)});
      q.plucker.insert(q.plucker.end(), 6, 0.f);
      q.normals.insert(q.normals.end(), {0, 0, -1});
      q.rays.insert(q.rays.end(), {0, 0, 1});
      q.depths.push_back(z);
      q.footprints.push_back(footprint);
      q.views.push_back(static_cast<int32_t>(v));
      q.pixels.push_back(static_cast<int32_t>(j));
      q.owners.push_back(owner);
      q.far.push_back(far ? 1 : 0);
    }
  }
  return q;
}

// Returns true if query `i` fused the same in `a` and `b`: the same
// observations, agreement and lifespan, and each colour channel within
// 1e-5 (the C++ kernel and the tensor version must agree to this).
inline bool SameFusedQuery(const FusedQueries& a, const FusedQueries& b, size_t i) {
  if (a.observations[i] != b.observations[i] || a.agreement[i] != b.agreement[i] ||
      a.lifespans[i] != b.lifespans[i]) {
    return false;
  }
  for (int c = 0; c < 3; ++c) {
    if (!(std::abs(a.rgb[3 * i + c] - b.rgb[3 * i + c]) < 1e-5f)) return false;
  }
  return true;
}

// An instance (owner 1) whose 4 x 2 x 1.5 m box slides 1 m along x, from
// (0, 0, 10) at time 0 to (1, 0, 10), turned a little, at `last_us`.
inline std::vector<InstanceTrack> SlidingTrack(int64_t last_us = 400000) {
  InstanceTrack track;
  track.id = "car";
  TrackBox first;
  first.center = {0, 0, 10};
  first.size = {4, 2, 1.5};
  TrackBox last = first;
  last.timestamp_us = std::max<int64_t>(last_us, 1);
  last.center = {1, 0, 10};
  last.rotation = QuatNormalized({1, 0, 0.05, 0});
  track.boxes = {first, last};
  return {track};
}

}  // namespace pf::testing

#endif  // POINTFORWARD_ENGINE_RECON_FUSION_TEST_UTIL_H_
