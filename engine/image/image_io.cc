// Image reading and writing on OpenImageIO.
#include "engine/image/image_io.h"

#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <memory>

#include "absl/strings/str_cat.h"
#include "common/file_util.h"
#include "common/status_macros.h"
#include "engine/image/oiio_write.h"

namespace pf {
namespace {

namespace fs = std::filesystem;
using OIIO::ImageInput;
using OIIO::ImageOutput;
using OIIO::ImageSpec;
using OIIO::TypeDesc;

absl::StatusOr<std::unique_ptr<ImageInput>> OpenInput(const std::string& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) return absl::NotFoundError(absl::StrCat(path, ": file not found"));
  auto in = ImageInput::open(path);
  if (!in) {
    return absl::InvalidArgumentError(
        absl::StrCat(path, ": not a readable image: ", OIIO::geterror()));
  }
  return in;
}

}  // namespace

absl::Status WriteImageAtomically(const std::string& path, const ImageSpec& spec,
                                  TypeDesc data_type, const void* data) {
  RETURN_IF_ERROR(MakeDirs(fs::path(path).parent_path().string()));
  const std::string temp = TempPathFor(path);
  auto fail = [&](const std::string& what) {
    std::error_code ec;
    fs::remove(temp, ec);
    return absl::InternalError(absl::StrCat(path, ": ", what));
  };
  try {
    auto out = ImageOutput::create(path);
    if (!out) return fail(absl::StrCat("no writer: ", OIIO::geterror()));
    if (!out->open(temp, spec)) {
      return fail(absl::StrCat("cannot open for writing: ", out->geterror()));
    }
    const bool wrote = out->write_image(data_type, data);
    const bool closed = out->close();
    if (!wrote || !closed) return fail(absl::StrCat("write failed: ", out->geterror()));
  } catch (const std::exception& e) {
    return fail(absl::StrCat("writer threw: ", e.what()));
  }
  return CommitTempFile(temp, path);
}

absl::StatusOr<ImageInfo> ReadImageInfo(const std::string& path) {
  ASSIGN_OR_RETURN(auto in, OpenInput(path));
  const ImageSpec& spec = in->spec();
  ImageInfo info;
  info.width = spec.width;
  info.height = spec.height;
  info.channels = spec.nchannels;
  info.format = in->format_name();
  in->close();
  return info;
}

namespace {

// Decodes the image at `path` as ReadImage does; `float_values` says whether
// the file stores float (or half) values.
absl::StatusOr<ImageF> DecodeImage(const std::string& path, int channels, bool* float_values) {
  ASSIGN_OR_RETURN(auto in, OpenInput(path));
  const ImageSpec& spec = in->spec();
  const auto base = TypeDesc::BASETYPE(spec.format.basetype);
  *float_values = base == TypeDesc::FLOAT || base == TypeDesc::HALF || base == TypeDesc::DOUBLE;
  ImageF stored(spec.width, spec.height, spec.nchannels);
  if (!in->read_image(0, 0, 0, spec.nchannels, TypeDesc::FLOAT, stored.pixels.data())) {
    return absl::InvalidArgumentError(absl::StrCat(path, ": cannot decode: ", in->geterror()));
  }
  in->close();
  if (channels <= 0 || channels == stored.channels) return stored;
  ImageF out(stored.width, stored.height, channels);
  for (int y = 0; y < stored.height; ++y) {
    for (int x = 0; x < stored.width; ++x) {
      for (int c = 0; c < channels; ++c) {
        float v;
        if (c < stored.channels && !(stored.channels == 1 && c > 0)) {
          v = stored.at(x, y, c);
        } else if (stored.channels < 3 && c < 3) {
          v = stored.at(x, y, 0);  // Grey (or grey+alpha) to colour.
        } else {
          v = 1.f;  // Missing alpha.
        }
        out.at(x, y, c) = v;
      }
    }
  }
  return out;
}

}  // namespace

absl::StatusOr<ImageF> ReadImage(const std::string& path, int channels) {
  bool float_values = false;
  return DecodeImage(path, channels, &float_values);
}

absl::StatusOr<ImageF> ReadColourImage(const std::string& path, int channels,
                                       std::optional<ColourEncoding> stored, ColourEncoding to) {
  bool float_values = false;
  ASSIGN_OR_RETURN(ImageF image, DecodeImage(path, channels, &float_values));
  const ColourEncoding from =
      stored.value_or(float_values ? ColourEncoding::kLinear : ColourEncoding::kSrgb);
  ConvertColours(image.pixels.data(), size_t(image.width) * image.height, image.channels,
                 std::min(image.channels, 3), from, to);
  return image;
}

absl::StatusOr<ImageF> ReadDepth(const std::string& path) {
  ASSIGN_OR_RETURN(auto in, OpenInput(path));
  const ImageSpec spec = in->spec();
  const std::string format = in->format_name();
  ImageF depth(spec.width, spec.height, 1);
  if (format == "openexr") {
    if (!in->read_image(0, 0, 0, 1, TypeDesc::FLOAT, depth.pixels.data())) {
      return absl::InvalidArgumentError(absl::StrCat(path, ": cannot decode: ", in->geterror()));
    }
  } else if (format == "png" && spec.format == TypeDesc::UINT16) {
    std::vector<uint16_t> raw(size_t(spec.width) * spec.height);
    if (!in->read_image(0, 0, 0, 1, TypeDesc::UINT16, raw.data())) {
      return absl::InvalidArgumentError(absl::StrCat(path, ": cannot decode: ", in->geterror()));
    }
    for (size_t i = 0; i < raw.size(); ++i) depth.pixels[i] = raw[i] / 256.f;
  } else {
    return absl::InvalidArgumentError(
        absl::StrCat(path, ": depth must be a float EXR or a 16-bit PNG (got ", format, ", ",
                     spec.format.c_str(), ")"));
  }
  in->close();
  for (float& d : depth.pixels) {
    if (!std::isfinite(d) || d < 0.f) d = 0.f;
  }
  return depth;
}

absl::Status WritePng(const std::string& path, const ImageF& image) {
  if (image.channels != 1 && image.channels != 3 && image.channels != 4) {
    return absl::InvalidArgumentError(
        absl::StrCat(path, ": PNG needs 1, 3 or 4 channels, got ", image.channels));
  }
  std::vector<uint8_t> bytes(image.pixels.size());
  for (size_t i = 0; i < bytes.size(); ++i) {
    const float v = std::isfinite(image.pixels[i]) ? image.pixels[i] : 0.f;
    bytes[i] = static_cast<uint8_t>(std::lround(std::clamp(v, 0.f, 1.f) * 255.f));
  }
  ImageSpec spec(image.width, image.height, image.channels, TypeDesc::UINT8);
  return WriteImageAtomically(path, spec, TypeDesc::UINT8, bytes.data());
}

absl::Status WriteDepthExr(const std::string& path, const ImageF& depth) {
  if (depth.channels != 1) {
    return absl::InvalidArgumentError(absl::StrCat(path, ": depth must have 1 channel"));
  }
  ImageSpec spec(depth.width, depth.height, 1, TypeDesc::FLOAT);
  spec.channelnames = {"Z"};
  spec.attribute("compression", "zip");
  return WriteImageAtomically(path, spec, TypeDesc::FLOAT, depth.pixels.data());
}

absl::Status ResizeImageFile(const std::string& src_path, const std::string& dst_path, int width,
                             int height, int jpeg_quality) {
  if (width <= 0 || height <= 0) {
    return absl::InvalidArgumentError(
        absl::StrCat(dst_path, ": resize to ", width, "x", height, ": size must be positive"));
  }
  ASSIGN_OR_RETURN(ImageF source, ReadImage(src_path));
  const ImageSpec source_spec(source.width, source.height, source.channels, TypeDesc::FLOAT);
  const OIIO::ImageBuf in(source_spec, source.pixels.data());
  OIIO::ImageBuf out(ImageSpec(width, height, source.channels, TypeDesc::FLOAT));
  // The box filter's width is in output pixels: 1 covers each output pixel's
  // footprint in the input.
  if (!OIIO::ImageBufAlgo::resize(out, in, "box", 1.0f)) {
    return absl::InternalError(absl::StrCat(src_path, ": resize failed: ", out.geterror()));
  }
  std::vector<uint8_t> bytes(size_t(width) * height * source.channels);
  if (!out.get_pixels(OIIO::ROI::All(), TypeDesc::UINT8, bytes.data())) {
    return absl::InternalError(absl::StrCat(src_path, ": resize failed: ", out.geterror()));
  }
  ImageSpec spec(width, height, source.channels, TypeDesc::UINT8);
  spec.attribute("compression", absl::StrCat("jpeg:", jpeg_quality));
  return WriteImageAtomically(dst_path, spec, TypeDesc::UINT8, bytes.data());
}

absl::Status WriteDepthPng16(const std::string& path, const ImageF& depth) {
  if (depth.channels != 1) {
    return absl::InvalidArgumentError(absl::StrCat(path, ": depth must have 1 channel"));
  }
  std::vector<uint16_t> raw(depth.pixels.size());
  for (size_t i = 0; i < raw.size(); ++i) {
    const float d = depth.pixels[i];
    raw[i] = (std::isfinite(d) && d > 0.f)
                 ? static_cast<uint16_t>(std::min(65535.f, std::round(d * 256.f)))
                 : 0;
  }
  ImageSpec spec(depth.width, depth.height, 1, TypeDesc::UINT16);
  return WriteImageAtomically(path, spec, TypeDesc::UINT16, raw.data());
}

}  // namespace pf
