// The tile kernel built with -mavx512f (16 lanes, a whole tile row); called
// only on CPUs with AVX-512F. Built with -ffp-contract=off: the lanes must
// round as the baseline's do, not fuse multiplies and adds.
#include "engine/render/raster_tile.h"
#include "engine/render/raster_tile_kernel.h"

namespace pf::raster {

void CompositeTileAvx512(TileJob* job) { CompositeTileFor<16>(job); }
void BlendPeakTileAvx512(const PeakGaussian* gaussians, int count, float* out) {
  BlendPeakTileFor<16>(gaussians, count, out);
}

}  // namespace pf::raster
