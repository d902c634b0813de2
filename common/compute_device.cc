// Parsing of --device.
#include "common/compute_device.h"

#include <charconv>
#include <string_view>

#include "absl/strings/str_cat.h"

namespace pf {

std::string ComputeDevice::ToString() const {
  return kind == Kind::kCpu ? "cpu" : absl::StrCat("cuda:", index);
}

absl::StatusOr<ComputeDevice> ParseComputeDevice(const std::string& spec,
                                                 const std::string& field) {
  ComputeDevice device;
  if (spec == "cpu") return device;
  device.kind = ComputeDevice::Kind::kCuda;
  if (spec == "cuda") return device;
  constexpr std::string_view kCuda = "cuda:";
  if (spec.substr(0, kCuda.size()) == kCuda) {
    const std::string number = spec.substr(kCuda.size());
    const auto [end, error] =
        std::from_chars(number.data(), number.data() + number.size(), device.index);
    if (!number.empty() && error == std::errc() && end == number.data() + number.size() &&
        device.index >= 0) {
      return device;
    }
  }
  return absl::InvalidArgumentError(absl::StrCat(
      field, ": unknown device '", spec, "' (expected cpu, cuda or cuda:N with N a GPU index)"));
}

}  // namespace pf
