// libFuzzer target: 3DGS PLY decoding (binary little/big-endian and ASCII)
// of arbitrary bytes. A decoded scene must also pass through encoding again.
#include <cstddef>
#include <cstdint>
#include <string>

#include "engine/render/ply_io.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  absl::StatusOr<pf::GaussianScene> scene = pf::DecodePly(bytes, "fuzz.ply");
  if (scene.ok()) (void)pf::EncodePly(*scene);
  return 0;
}
