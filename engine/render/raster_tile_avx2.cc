// The tile kernel built with -mavx2 (8 lanes); called only on CPUs with AVX2.
#include "engine/render/raster_tile.h"
#include "engine/render/raster_tile_kernel.h"

namespace pf::raster {

void CompositeTileAvx2(TileJob* job) { CompositeTileFor<8>(job); }

}  // namespace pf::raster
