// Writes an image file with OpenImageIO under a temporary name and renames
// it, for writers that build their own ImageSpec (EXR layers and header
// attributes). Includes OpenImageIO: in a file that also includes
// protobuf-generated headers, include those first.
#ifndef POINTFORWARD_ENGINE_IMAGE_OIIO_WRITE_H_
#define POINTFORWARD_ENGINE_IMAGE_OIIO_WRITE_H_

#include <OpenImageIO/imageio.h>

#include <string>

#include "absl/status/status.h"

namespace pf {

// Writes `data` (pixels of `data_type`, or of the spec's channel formats for
// TypeDesc::UNKNOWN) as `spec` to `path`, in the format its extension names,
// creating its directory. INTERNAL with OpenImageIO's message if writing fails
// (the temporary file removed); nothing is left at `path` then.
absl::Status WriteImageAtomically(const std::string& path, const OIIO::ImageSpec& spec,
                                  OIIO::TypeDesc data_type, const void* data);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_IMAGE_OIIO_WRITE_H_
