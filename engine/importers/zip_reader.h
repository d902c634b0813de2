// A minimal reader of ZIP archives (as numpy's .npz files are): lists the
// entries from the central directory and extracts stored or deflated ones,
// checking each entry's CRC-32. ZIP64 and encrypted entries are rejected.
#ifndef POINTFORWARD_ENGINE_IMPORTERS_ZIP_READER_H_
#define POINTFORWARD_ENGINE_IMPORTERS_ZIP_READER_H_

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/statusor.h"

namespace pf {

class ZipReader {
 public:
  struct Entry {
    std::string name;
    uint16_t method = 0;  // 0 stored, 8 deflated.
    uint32_t crc32 = 0;
    uint64_t compressed_size = 0;
    uint64_t size = 0;
    uint64_t local_header_offset = 0;
  };

  // Reads the archive `path` into memory and parses its central directory.
  // NOT_FOUND if it cannot be read; DATA_LOSS naming the path when it is not a
  // readable ZIP.
  static absl::StatusOr<ZipReader> Open(const std::string& path);
  // The same over bytes already in memory; `label` names them in errors.
  static absl::StatusOr<ZipReader> FromBytes(std::string bytes, std::string label);

  const std::vector<Entry>& entries() const { return entries_; }

  // Returns the uncompressed bytes of entry `name`. NOT_FOUND listing the
  // entries when absent; UNIMPLEMENTED for a method other than stored or
  // deflated; DATA_LOSS when inflating fails or the CRC does not match.
  absl::StatusOr<std::string> Read(const std::string& name) const;

 private:
  std::string label_;
  std::string bytes_;
  std::vector<Entry> entries_;
};

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_IMPORTERS_ZIP_READER_H_
