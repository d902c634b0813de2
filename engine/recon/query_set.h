// The sparse queries of a reconstruction, structure of arrays. Static
// queries (owner 0) live in world space; an instance's queries (owner k)
// live in the canonical frame of its first box (scene_graph.h), and so do
// their normals and rays.
#ifndef POINTFORWARD_ENGINE_RECON_QUERY_SET_H_
#define POINTFORWARD_ENGINE_RECON_QUERY_SET_H_

#include <cstdint>
#include <vector>

#include "common/geometry.h"

namespace pf {

struct QuerySet {
  std::vector<float> positions;   // [N, 3] world (static) or canonical (dynamic)
  std::vector<float> rgb;         // [N, 3] colour of the source pixel
  std::vector<float> plucker;     // [N, 6] (d, o x d) of the source ray, world
  std::vector<float> normals;     // [N, 3] unit, same frame as positions
  std::vector<float> rays;        // [N, 3] unit source view direction, same frame as positions
  std::vector<float> depths;      // [N] z depth in the source view
  std::vector<float> footprints;  // [N] metres between neighbouring queries, across the ray
  std::vector<int32_t> views;     // [N] source view index
  std::vector<int32_t> pixels;    // [N] source pixel y * W + x
  std::vector<uint32_t> owners;   // [N] 0 static, k: instance k - 1
  std::vector<uint8_t> far;       // [N] 1 on the far layer
  // [N] 1 for a hidden query (sparse_sampling.h): behind the surface its
  // source pixel sees, coloured like the background next to it; may be
  // empty (none hidden).
  std::vector<uint8_t> hidden;

  size_t size() const { return depths.size(); }
  Vec3 position(size_t i) const {
    return {positions[3 * i], positions[3 * i + 1], positions[3 * i + 2]};
  }
  Vec3 normal(size_t i) const { return {normals[3 * i], normals[3 * i + 1], normals[3 * i + 2]}; }
  Vec3 ray(size_t i) const { return {rays[3 * i], rays[3 * i + 1], rays[3 * i + 2]}; }
  bool is_hidden(size_t i) const { return i < hidden.size() && hidden[i] != 0; }
};

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RECON_QUERY_SET_H_
