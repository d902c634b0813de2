// Colour encodings: what the numbers of an image or of a scene's colours mean.
//
// Camera images (8-bit PNG, JPEG) hold sRGB-encoded values; EXR files hold
// scene-linear light (Rec. 709 / sRGB primaries, D65 white). The sRGB
// transfer functions are the exact piecewise ones of IEC 61966-2-1, not a
// 2.2 power. Values outside [0, 1] (a fitted colour's overshoot) are mapped
// through the odd extension, sign(v) f(|v|), so the functions stay inverse
// to each other over all reals.
#ifndef POINTFORWARD_COMMON_COLOUR_SPACE_H_
#define POINTFORWARD_COMMON_COLOUR_SPACE_H_

#include <cmath>
#include <string>

#include "absl/status/statusor.h"

namespace pf {

enum class ColourEncoding {
  kSrgb,    // sRGB-encoded values, as 8-bit camera images and displays hold them.
  kLinear,  // Scene-linear light, Rec. 709 primaries (EXR's convention).
};

// Returns "srgb" or "linear".
const char* ColourEncodingName(ColourEncoding encoding);

// Parses "srgb" or "linear"; INVALID_ARGUMENT naming `field` otherwise.
absl::StatusOr<ColourEncoding> ParseColourEncoding(const std::string& text,
                                                   const std::string& field);

// The sRGB EOTF: an encoded value to linear light.
inline float SrgbToLinear(float v) {
  const float a = std::fabs(v);
  const float linear = a <= 0.04045f ? a / 12.92f : std::pow((a + 0.055f) / 1.055f, 2.4f);
  return std::copysign(linear, v);
}

// The inverse: linear light to an sRGB-encoded value.
inline float LinearToSrgb(float v) {
  const float a = std::fabs(v);
  const float encoded = a <= 0.0031308f ? 12.92f * a : 1.055f * std::pow(a, 1 / 2.4f) - 0.055f;
  return std::copysign(encoded, v);
}

// Returns `v` (in `from`) in `to`.
inline float ConvertColour(float v, ColourEncoding from, ColourEncoding to) {
  if (from == to) return v;
  return to == ColourEncoding::kLinear ? SrgbToLinear(v) : LinearToSrgb(v);
}

// Converts the first `colour_channels` channels of each of `pixels` interleaved
// pixels of `channels` channels, in place.
void ConvertColours(float* data, size_t pixels, int channels, int colour_channels,
                    ColourEncoding from, ColourEncoding to);

}  // namespace pf

#endif  // POINTFORWARD_COMMON_COLOUR_SPACE_H_
