// Walks JPEG marker segments up to the first start-of-frame.
#include "engine/importers/jpeg_header.h"

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"

namespace pf {

absl::StatusOr<JpegSize> ReadJpegSize(std::string_view bytes, const std::string& label) {
  auto byte = [&](size_t i) { return static_cast<unsigned char>(bytes[i]); };
  if (bytes.size() < 4 || byte(0) != 0xFF || byte(1) != 0xD8) {
    return absl::InvalidArgumentError(absl::StrCat(label, ": not a JPEG (no SOI marker)"));
  }
  size_t at = 2;
  while (at + 4 <= bytes.size()) {
    if (byte(at) != 0xFF) break;
    const unsigned char marker = byte(at + 1);
    if (marker == 0xFF) {  // Fill byte.
      ++at;
      continue;
    }
    if (marker == 0xD8 || marker == 0x01 || (marker >= 0xD0 && marker <= 0xD7)) {
      at += 2;  // Markers without a length.
      continue;
    }
    const size_t length = (static_cast<size_t>(byte(at + 2)) << 8) | byte(at + 3);
    const bool is_sof =
        marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC;
    if (is_sof) {
      if (at + 9 > bytes.size()) break;
      JpegSize size;
      size.height = (byte(at + 5) << 8) | byte(at + 6);
      size.width = (byte(at + 7) << 8) | byte(at + 8);
      return size;
    }
    if (marker == 0xDA || length < 2) break;  // Start of scan before any SOF.
    at += 2 + length;
  }
  return absl::InvalidArgumentError(
      absl::StrCat(label, ": JPEG ends or is damaged before its start-of-frame marker"));
}

}  // namespace pf
