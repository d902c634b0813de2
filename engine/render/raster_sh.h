// Real spherical harmonics colour evaluation (degrees 0-3), as 3DGS tools
// store them: per colour channel (deg+1)^2 coefficients, evaluated for a unit
// view direction, plus 0.5, clamped at 0. Shared by the rasterizer and its
// test reference.
#ifndef POINTFORWARD_ENGINE_RENDER_RASTER_SH_H_
#define POINTFORWARD_ENGINE_RENDER_RASTER_SH_H_

#include <algorithm>
#include <cmath>

#include "common/host_device.h"

namespace pf::raster {

// Returns in `rgb` the colour of `coeffs` ([3, (degree+1)^2], channel-major)
// seen along unit direction (x, y, z) (from the camera towards the Gaussian).
PF_HD inline void EvalShColor(const float* coeffs, int degree, float x, float y, float z,
                              float rgb[3]) {
  constexpr float kC0 = 0.28209479177387814f;
  constexpr float kC1 = 0.4886025119029199f;
  constexpr float kC2[5] = {1.0925484305920792f, -1.0925484305920792f, 0.31539156525252005f,
                            -1.0925484305920792f, 0.5462742152960396f};
  constexpr float kC3[7] = {-0.5900435899266435f, 2.890611442640554f,   -0.4570457994644658f,
                            0.3731763325901154f,  -0.4570457994644658f, 1.445305721320277f,
                            -0.5900435899266435f};
  const int n = (degree + 1) * (degree + 1);
  float basis[16];
  basis[0] = kC0;
  if (degree >= 1) {
    basis[1] = -kC1 * y;
    basis[2] = kC1 * z;
    basis[3] = -kC1 * x;
  }
  if (degree >= 2) {
    const float xx = x * x, yy = y * y, zz = z * z, xy = x * y, yz = y * z, xz = x * z;
    basis[4] = kC2[0] * xy;
    basis[5] = kC2[1] * yz;
    basis[6] = kC2[2] * (2.f * zz - xx - yy);
    basis[7] = kC2[3] * xz;
    basis[8] = kC2[4] * (xx - yy);
    if (degree >= 3) {
      basis[9] = kC3[0] * y * (3.f * xx - yy);
      basis[10] = kC3[1] * xy * z;
      basis[11] = kC3[2] * y * (4.f * zz - xx - yy);
      basis[12] = kC3[3] * z * (2.f * zz - 3.f * xx - 3.f * yy);
      basis[13] = kC3[4] * x * (4.f * zz - xx - yy);
      basis[14] = kC3[5] * z * (xx - yy);
      basis[15] = kC3[6] * x * (xx - 3.f * yy);
    }
  }
  for (int c = 0; c < 3; ++c) {
    float sum = 0.f;
    for (int k = 0; k < n; ++k) sum += coeffs[c * n + k] * basis[k];
    const float value = sum + 0.5f;
    rgb[c] = value > 0.f ? value : 0.f;
  }
}

// Returns in `rgb` the colour of `coeffs` for a Gaussian at `mean` seen from
// `eye` (both in the frame the SH live in, the owner's).
PF_HD inline void EvalShColorFrom(const float* coeffs, int degree, const float* mean,
                                  const float* eye, float rgb[3]) {
  float x = mean[0] - eye[0], y = mean[1] - eye[1], z = mean[2] - eye[2];
  const float norm = std::sqrt(x * x + y * y + z * z);
  if (norm > 0) x /= norm, y /= norm, z /= norm;
  EvalShColor(coeffs, degree, x, y, z, rgb);
}

}  // namespace pf::raster

#endif  // POINTFORWARD_ENGINE_RENDER_RASTER_SH_H_
