// Inputs shared by the fusion tests (fusion_test.cc, tensor_fusion_test.cc).
#ifndef POINTFORWARD_WORKER_ENGINE_RECON_FUSION_TEST_UTIL_H_
#define POINTFORWARD_WORKER_ENGINE_RECON_FUSION_TEST_UTIL_H_

#include <cstdint>

#include "worker/engine/recon/query_set.h"

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

}  // namespace pf::testing

#endif  // POINTFORWARD_WORKER_ENGINE_RECON_FUSION_TEST_UTIL_H_
