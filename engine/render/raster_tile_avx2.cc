// The tile kernel built with -mavx2 (8 lanes); called only on CPUs with AVX2.
#include "engine/render/raster_tile.h"
#include "engine/render/raster_tile_kernel.h"

namespace pf::raster {

void CompositeTileAvx2(TileJob* job) { CompositeTileFor<8>(job); }
void BlendPeakTileAvx2(const PeakGaussian* gaussians, int count, float* out) {
  BlendPeakTileFor<8>(gaussians, count, out);
}

}  // namespace pf::raster
