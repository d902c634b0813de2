// AccumulateNormal's textured product built with AVX2: each entry's 8 first
// coefficients (w, w u, w v per channel) in one vector, where the baseline
// (compositing_weights.cc) takes three 4-wide ones; every sum runs over the
// same terms in the same order, so both give the same bits. The recording's
// tile loop at 8 lanes (compositing_weights_tile.h).
#include "engine/render/compositing_weights_avx2.h"

#include <cstdint>
#include <cstring>
#include <vector>

namespace pf {
namespace {

typedef float V8 __attribute__((vector_size(32)));

// One entry of the pixel at work: its (w, w u, w v) laid out as the
// Gaussian's first 8 parameters take them, the parameters' address in the
// output and the ninth's coefficient w v.
struct PixelEntry {
  V8 coef;
  float* out;
  float wv;
};

}  // namespace

void AccumulateNormalTexturedAvx2(const CompositingWeights& a, const std::vector<uint8_t>& mask,
                                  const float* x, float* out, const TableScratch& scratch) {
  std::vector<PixelEntry> row;
  ForEachMaskedPixelByTable(
      a, mask, x, out, scratch, [&](uint64_t begin, uint64_t count, float px, float py) {
        if (row.size() < count) row.resize(count);
        V8 sums = {0, 0, 0, 0, 0, 0, 0, 0};
        float sum8 = 0.f;
        for (uint64_t k = 0; k < count; ++k) {
          const auto [w, wu, wv, offset] = TexturedEntryAt(a, scratch, begin + k, px, py);
          const float* src = scratch.x + offset;
          const V8 coef = {w, wu, wv, w, wu, wv, w, wu};
          V8 params;  // The first 8 of the Gaussian's 9.
          std::memcpy(&params, src, sizeof(params));
          sums += coef * params;
          sum8 += wv * src[8];
          row[k] = {coef, scratch.out + offset, wv};
        }
        // (A x)_p per channel; the "+ 0.f" terms keep the baseline's sums,
        // whose fourth lanes sum zeros.
        const float v0 = (sums[0] + sums[1]) + (sums[2] + 0.f);
        const float v1 = (sums[3] + sums[4]) + (sums[5] + 0.f);
        const float v2 = (0.f + sums[6]) + (sums[7] + sum8);
        const V8 values = {v0, v0, v0, v1, v1, v1, v2, v2};
        for (uint64_t k = 0; k < count; ++k) {
          const PixelEntry& entry = row[k];
          V8 sum;
          std::memcpy(&sum, entry.out, sizeof(sum));
          sum += entry.coef * values;
          std::memcpy(entry.out, &sum, sizeof(sum));
          entry.out[8] += entry.wv * v2;
        }
      });
}

void RecordTileAvx2(const weights_tile::Tile& tile) { RecordTileLanes<8>(tile); }

}  // namespace pf
