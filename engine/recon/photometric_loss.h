// The loss the scene optimisation minimises per context view, and its
// gradient with respect to the rendered image:
//
//   L = (1 - lambda) L1 + lambda (1 - SSIM),
//
// L1 the mean absolute difference over the counted pixels and the 3
// channels, SSIM the mean SSIM of image_metrics.h (11 x 11 Gaussian window,
// sigma 1.5, C1 = 0.01^2, C2 = 0.03^2, per channel over the fully inside
// windows centred on counted pixels, averaged), lambda = 0.2 as 3DGS.
#ifndef POINTFORWARD_ENGINE_RECON_PHOTOMETRIC_LOSS_H_
#define POINTFORWARD_ENGINE_RECON_PHOTOMETRIC_LOSS_H_

#include <cstdint>
#include <vector>

#include "engine/image/image_io.h"

namespace pf {

struct PhotometricLoss {
  double value = 0;          // L.
  double l1 = 0;             // Mean absolute difference.
  double ssim = 0;           // Mean SSIM (1 when the image has no full window).
  double mse = 0;            // Mean squared difference (for PSNR).
  int64_t ssim_windows = 0;  // Windows the SSIM is the mean of.
};

// L of `render` ([H, W, 3], truth's size) against `truth`, over the pixels
// where `counted` ([H * W]) is non-zero (all when empty), and, when
// `gradient` is given, dL/d render into it ([H, W, 3]; zero on pixels no
// term reads).
PhotometricLoss PhotometricLossAndGradient(const float* render, const ImageF& truth,
                                           const std::vector<uint8_t>& counted, double ssim_weight,
                                           std::vector<float>* gradient);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RECON_PHOTOMETRIC_LOSS_H_
