// Reading and writing the images a clip references: colour images (PNG,
// JPEG, EXR) and depth maps (float EXR, 16-bit PNG). Everything goes through
// OpenImageIO; its errors come back as Status with the path attached.
//
// Keep protobuf-generated headers out of files that include this one's .cc
// dependencies (OpenImageIO/OpenEXR headers break them); this header itself
// includes no image library.
#ifndef POINTFORWARD_ENGINE_IMAGE_IMAGE_IO_H_
#define POINTFORWARD_ENGINE_IMAGE_IMAGE_IO_H_

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "common/colour_space.h"

namespace pf {

// What a file's header says, without decoding pixels.
struct ImageInfo {
  int width = 0;
  int height = 0;
  int channels = 0;
  std::string format;  // OpenImageIO's format name: "png", "jpeg", "openexr".
};

// A float image, interleaved: pixels[(y * width + x) * channels + c].
struct ImageF {
  int width = 0;
  int height = 0;
  int channels = 0;
  std::vector<float> pixels;  // [height, width, channels]

  ImageF() = default;
  ImageF(int w, int h, int c) : width(w), height(h), channels(c), pixels(size_t(w) * h * c, 0.f) {}
  float& at(int x, int y, int c = 0) { return pixels[(size_t(y) * width + x) * channels + c]; }
  float at(int x, int y, int c = 0) const { return pixels[(size_t(y) * width + x) * channels + c]; }
};

// Returns the header facts of the image at `path`: NOT_FOUND when missing,
// INVALID_ARGUMENT when it is not a readable image.
absl::StatusOr<ImageInfo> ReadImageInfo(const std::string& path);

// Decodes the image at `path` to floats. 8- and 16-bit formats map to [0, 1];
// float formats keep their values. With `channels` > 0 the result has exactly
// that many channels (extra ones dropped; a single grey channel repeated;
// missing alpha filled with 1).
absl::StatusOr<ImageF> ReadImage(const std::string& path, int channels = 0);

// Reads the colour image at `path` as ReadImage does and returns its colour
// channels (the first three; alpha is left alone) in `to`. `stored` is the
// encoding of the file's values (a camera's declared colour space); without
// it, float and half files (EXR) hold linear light and integer ones (PNG,
// JPEG) sRGB-encoded values.
absl::StatusOr<ImageF> ReadColourImage(const std::string& path, int channels,
                                       std::optional<ColourEncoding> stored, ColourEncoding to);

// Reads a depth map in metres along z: a float EXR (first channel) or a 16-bit
// PNG whose value / 256 is metres. 0 (or a non-finite value) means unknown.
// Any other format or bit depth is INVALID_ARGUMENT.
absl::StatusOr<ImageF> ReadDepth(const std::string& path);

// Writes `image` (1, 3 or 4 channels, values in [0, 1]) as an 8-bit PNG,
// atomically (temporary file, then rename).
absl::Status WritePng(const std::string& path, const ImageF& image);

// Writes a one-channel float EXR whose channel is named "Z" (ZIP
// compression), atomically. Used for depth maps.
absl::Status WriteDepthExr(const std::string& path, const ImageF& depth);

// Writes the image at `src_path` resized to `width` x `height` with an area
// (box) filter: each output pixel averages the input pixels its footprint
// covers (the filter is one output pixel wide). The output is 8-bit with the
// input's channels, its format chosen by `dst_path`'s extension (JPEG at
// quality `jpeg_quality`), written atomically. Errors as ReadImage for the
// input; INVALID_ARGUMENT for a non-positive size.
absl::Status ResizeImageFile(const std::string& src_path, const std::string& dst_path, int width,
                             int height, int jpeg_quality = 95);

// Writes a 16-bit PNG depth map (value = metres * 256, clamped to 65535, 0 for
// unknown or non-finite), atomically.
absl::Status WriteDepthPng16(const std::string& path, const ImageF& depth);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_IMAGE_IMAGE_IO_H_
