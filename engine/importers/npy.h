// A parser of NumPy .npy arrays (format versions 1-3) of little-endian
// float32 or float64, C order, converted to float64.
#ifndef POINTFORWARD_ENGINE_IMPORTERS_NPY_H_
#define POINTFORWARD_ENGINE_IMPORTERS_NPY_H_

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"

namespace pf {

struct NpyArray {
  std::vector<int64_t> shape;
  std::vector<double> data;  // Row-major, product(shape) values.
};

// Parses `bytes` (a whole .npy file). INVALID_ARGUMENT naming `label` for a
// bad magic or header, an unsupported dtype ('<f4' and '<f8' only), Fortran
// order, or a payload whose size does not match the shape.
absl::StatusOr<NpyArray> ParseNpy(std::string_view bytes, const std::string& label);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_IMPORTERS_NPY_H_
