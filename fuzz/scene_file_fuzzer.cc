// libFuzzer target: our scene file reader (ReadSceneFile). It reads a path,
// so each input is written to one temporary file per process.
//
// The file ends in a SHA-256 of everything before it, which random mutation
// would practically never match; the target therefore overwrites the last 32
// bytes with the right digest, so that mutations reach the array reads and
// ValidateScene() behind the checksum. (The mismatch branch itself is a plain
// comparison, covered by scene_file_test.)
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "common/hash.h"
#include "engine/render/scene_file.h"
#include "fuzz/fuzz_temp_file.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const pf::FuzzTempFile file("pfscene");
  constexpr size_t kDigestBytes = 32;
  std::vector<uint8_t> bytes(data, data + size);
  if (bytes.size() >= kDigestBytes) {
    pf::Sha256 hasher;
    hasher.Update(bytes.data(), bytes.size() - kDigestBytes);
    const std::array<uint8_t, 32> digest = hasher.Finish();
    std::memcpy(bytes.data() + bytes.size() - kDigestBytes, digest.data(), kDigestBytes);
  }
  file.Write(bytes.data(), bytes.size());
  absl::StatusOr<pf::SceneFile> scene = pf::ReadSceneFile(file.path());
  // Whatever loads must be a scene the rest of the engine accepts.
  if (scene.ok() && !pf::ValidateScene(scene->scene).ok()) abort();
  return 0;
}
