// sRGB and linear colour encodings (colour_space.h).
#include "common/colour_space.h"

#include "absl/strings/str_cat.h"

namespace pf {

const char* ColourEncodingName(ColourEncoding encoding) {
  return encoding == ColourEncoding::kLinear ? "linear" : "srgb";
}

absl::StatusOr<ColourEncoding> ParseColourEncoding(const std::string& text,
                                                   const std::string& field) {
  if (text == "srgb") return ColourEncoding::kSrgb;
  if (text == "linear") return ColourEncoding::kLinear;
  return absl::InvalidArgumentError(
      absl::StrCat(field, ": unknown colour encoding '", text, "' (srgb or linear)"));
}

void ConvertColours(float* data, size_t pixels, int channels, int colour_channels,
                    ColourEncoding from, ColourEncoding to) {
  if (from == to) return;
  for (size_t i = 0; i < pixels; ++i) {
    float* pixel = data + i * channels;
    for (int c = 0; c < colour_channels; ++c) pixel[c] = ConvertColour(pixel[c], from, to);
  }
}

}  // namespace pf
