// Content hashing: SHA-256 over bytes and files, as lowercase hex.
//
// Content hashes key the scene cache and the blob store, so they must be
// stable across machines and releases: SHA-256 (FIPS 180-4), nothing custom.
#ifndef POINTFORWARD_COMMON_HASH_H_
#define POINTFORWARD_COMMON_HASH_H_

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "absl/status/statusor.h"

namespace pf {

// Incremental SHA-256.
class Sha256 {
 public:
  Sha256();
  // Adds `size` bytes at `data`.
  void Update(const void* data, size_t size);
  void Update(std::string_view bytes) { Update(bytes.data(), bytes.size()); }
  // Returns the 32-byte digest. The hasher must not be updated afterwards.
  std::array<uint8_t, 32> Finish();
  // Returns the digest as 64 lowercase hex characters.
  std::string FinishHex();

 private:
  void Compress(const uint8_t* block);

  std::array<uint32_t, 8> state_;
  std::array<uint8_t, 64> buffer_;
  size_t buffered_ = 0;
  uint64_t total_bytes_ = 0;
};

// Returns the hex SHA-256 of `bytes`.
std::string Sha256Hex(std::string_view bytes);

// Returns the hex SHA-256 of the file at `path`; NOT_FOUND or
// PERMISSION_DENIED/INTERNAL naming the path when it cannot be read.
absl::StatusOr<std::string> Sha256File(const std::string& path);

// Returns `bytes` as lowercase hex.
std::string ToHex(const uint8_t* bytes, size_t size);

}  // namespace pf

#endif  // POINTFORWARD_COMMON_HASH_H_
