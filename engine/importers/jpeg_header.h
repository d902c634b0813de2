// Reads the image size from a JPEG's start-of-frame marker without decoding
// it, so importers can check a camera's calibrated size against its images.
#ifndef POINTFORWARD_ENGINE_IMPORTERS_JPEG_HEADER_H_
#define POINTFORWARD_ENGINE_IMPORTERS_JPEG_HEADER_H_

#include <string>
#include <string_view>

#include "absl/status/statusor.h"

namespace pf {

struct JpegSize {
  int width = 0;
  int height = 0;
};

// Returns the size in the first SOFn marker of `bytes`. INVALID_ARGUMENT
// naming `label` when the bytes are not a JPEG or end before a SOF marker.
absl::StatusOr<JpegSize> ReadJpegSize(std::string_view bytes, const std::string& label);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_IMPORTERS_JPEG_HEADER_H_
