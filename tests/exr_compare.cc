// Reading EXRs back and comparing them (exr_compare.h).
#include "tests/exr_compare.h"

#include <OpenImageIO/imageio.h>

#include <cmath>

namespace pf::testing {

std::map<std::string, std::vector<float>> ReadExr(const std::string& path) {
  std::map<std::string, std::vector<float>> out;
  auto in = OIIO::ImageInput::open(path);
  if (!in) return out;
  const OIIO::ImageSpec& spec = in->spec();
  const size_t count = static_cast<size_t>(spec.width) * spec.height;
  std::vector<float> pixels(count * spec.nchannels);
  if (!in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, pixels.data())) return out;
  for (int c = 0; c < spec.nchannels; ++c) {
    std::vector<float>& channel = out[spec.channelnames[c]];
    for (size_t p = 0; p < count; ++p) channel.push_back(pixels[p * spec.nchannels + c]);
  }
  return out;
}

double RgbPsnr(const std::string& a_path, const std::string& b_path) {
  const auto a = ReadExr(a_path);
  const auto b = ReadExr(b_path);
  double squared = 0;
  size_t count = 0;
  for (const char* name : {"R", "G", "B"}) {
    if (!a.count(name) || !b.count(name) || a.at(name).size() != b.at(name).size()) return -1;
    for (size_t i = 0; i < a.at(name).size(); ++i) {
      const double d = a.at(name)[i] - b.at(name)[i];
      squared += d * d;
      ++count;
    }
  }
  if (count == 0) return -1;
  if (squared == 0) return INFINITY;
  return 10 * std::log10(1.0 / (squared / count));
}

}  // namespace pf::testing
