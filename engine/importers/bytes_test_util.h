// Test helper for the importer readers' tests: integers as little-endian bytes,
// to build TFRecord and ZIP inputs by hand.
#ifndef POINTFORWARD_ENGINE_IMPORTERS_BYTES_TEST_UTIL_H_
#define POINTFORWARD_ENGINE_IMPORTERS_BYTES_TEST_UTIL_H_

#include <cstdint>
#include <string>

namespace pf::testing {

// Returns the low `bytes` bytes of `v`, least significant first.
inline std::string Le(uint64_t v, int bytes) {
  std::string out;
  for (int i = 0; i < bytes; ++i) out.push_back(static_cast<char>((v >> (8 * i)) & 0xFF));
  return out;
}

}  // namespace pf::testing

#endif  // POINTFORWARD_ENGINE_IMPORTERS_BYTES_TEST_UTIL_H_
