// The colour fit's per-Gaussian arithmetic (colour_refinement.h), shared by
// its CPU solve (colour_refinement.cc) and its GPU one (cuda_colour_fit.cu).
#ifndef POINTFORWARD_ENGINE_RECON_COLOUR_FIT_BLOCKS_H_
#define POINTFORWARD_ENGINE_RECON_COLOUR_FIT_BLOCKS_H_

#include "common/host_device.h"

namespace pf::colour_fit {

// Per Gaussian, sums over the fitted pixels of every view (kSums floats,
// the same for the three channels): w^2, (w u)^2, (w v)^2, w^2 u, w^2 v,
// w^2 u v (its block of A^T M A; u, v the local coordinates, 0 for flat
// colours) and alpha^2 = (w / T)^2, T the transmittance left by the
// entries in front (1 - their summed weight; the few under min_weight are
// not counted): the Gaussian's data weight with nothing in front of it.
constexpr int kSums = 7;

// The transmittance under which alpha_ip = w_ip / T is not trusted.
constexpr float kMinTransmittance = 1e-4f;

// z = B^-1 r for one Gaussian's unknowns ([3, k]: per RGB channel the colour
// and, for k = 3, its two gradients): `inverse` is B^-1, one float for k = 1,
// the symmetric 3x3 as (00, 01, 02, 11, 12, 22) for k = 3, the same for
// the three channels.
PF_HD inline void PreconditionBlock(const float* inverse, int k, const float* r, float* z) {
  if (k == 1) {
    for (int c = 0; c < 3; ++c) z[c] = inverse[0] * r[c];
    return;
  }
  const float* m = inverse;
  for (int c = 0; c < 3; ++c) {
    const float r0 = r[3 * c], r1 = r[3 * c + 1], r2 = r[3 * c + 2];
    z[3 * c] = m[0] * r0 + m[1] * r1 + m[2] * r2;
    z[3 * c + 1] = m[1] * r0 + m[3] * r1 + m[4] * r2;
    z[3 * c + 2] = m[2] * r0 + m[4] * r1 + m[5] * r2;
  }
}

}  // namespace pf::colour_fit

#endif  // POINTFORWARD_ENGINE_RECON_COLOUR_FIT_BLOCKS_H_
