// Image-quality figures `pf eval` reports, over float RGB images in [0, 1]
// ([H, W, 3], ImageF), and the contact sheet a person looks at.
//
// - PSNR: 10 log10(1 / MSE) over the selected pixels and the 3 channels;
//   capped at kMaxPsnr for identical images.
// - SSIM: Wang et al. 2004 with an 11 x 11 Gaussian window (sigma 1.5),
//   C1 = (0.01)^2, C2 = (0.03)^2, computed per channel over the valid
//   (fully inside) windows and averaged.
// - Depth RMSE: over pixels where the truth has depth (> 0, finite).
#ifndef POINTFORWARD_ENGINE_RECON_IMAGE_METRICS_H_
#define POINTFORWARD_ENGINE_RECON_IMAGE_METRICS_H_

#include <cstdint>
#include <optional>
#include <vector>

#include "engine/image/image_io.h"

namespace pf {

inline constexpr double kMaxPsnr = 100.0;

// Returns the PSNR of `test` against `truth` (same size, 3 channels) over
// the pixels where `mask` is non-zero (all when `mask` is empty); nullopt when
// no pixel is selected.
std::optional<double> Psnr(const ImageF& truth, const ImageF& test,
                           const std::vector<uint8_t>& mask = {});

// Returns the mean SSIM of `test` against `truth` (same size, 3 channels)
// over the windows centred on pixels where `mask` is non-zero (all when
// `mask` is empty). Images smaller than the window, or no window selected,
// give nullopt.
std::optional<double> Ssim(const ImageF& truth, const ImageF& test,
                           const std::vector<uint8_t>& mask = {});

// Returns the root mean square of (test - truth) over pixels where truth is
// > 0 and finite, and the count through `pixels`; nullopt when there is none.
std::optional<double> DepthRmse(const ImageF& truth, const ImageF& test, int64_t* pixels = nullptr);

// Returns truth | test | heat map of the mean absolute error (black 0, red,
// yellow, white at `max_error`) side by side, [H, 3W, 3].
ImageF ContactSheet(const ImageF& truth, const ImageF& test, double max_error = 0.25);

// Returns a line chart of `values` (one per step, left to right) on white,
// [height, width, 3]: the values in light blue, their running mean over
// `window` steps in dark red, scaled so the smallest and largest finite
// value span the plot (a frame marks its edges). No text: the numbers are
// in the report beside it.
ImageF LineChart(const std::vector<float>& values, int window, int width = 640, int height = 240);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RECON_IMAGE_METRICS_H_
