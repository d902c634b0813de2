// Shared by the depth-from-views tests (facade_depth_test.cc,
// stereo_depth_test.cc): the texture of their synthetic streets.
#ifndef POINTFORWARD_ENGINE_RECON_STREET_TEST_UTIL_H_
#define POINTFORWARD_ENGINE_RECON_STREET_TEST_UTIL_H_

#include <cstdint>

namespace pf::testing {

// A value in [0, 1) fixed by a cell's integer coordinates (a, b) and a
// channel or surface `c`, unrelated between neighbouring cells: a texture
// that two views match only where they see the same cell.
inline double HashedCell(int a, int b, int c) {
  uint32_t h = static_cast<uint32_t>(a) * 73856093u ^ static_cast<uint32_t>(b) * 19349663u ^
               static_cast<uint32_t>(c) * 83492791u;
  h ^= h >> 13;
  h *= 0x5bd1e995u;
  h ^= h >> 15;
  return (h % 1000) / 1000.0;
}

}  // namespace pf::testing

#endif  // POINTFORWARD_ENGINE_RECON_STREET_TEST_UTIL_H_
