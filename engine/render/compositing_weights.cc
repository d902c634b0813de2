// Recording the compositing weights of one render (the colour-linear map).
//
// The projection is the rasterizer's own (splat_projection.h: the same
// centres, conics and extents); the compositing runs raster_tile_kernel.h's
// per-row spans, pixel groups and lane arithmetic (compositing_weights_tile.h),
// 4 lanes wide, or 8 with AVX2, so the weights are the ones the render blends
// with, to the bit.
#include "engine/render/compositing_weights.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <optional>

#include "absl/strings/str_cat.h"
#include "engine/render/compositing_weights_avx2.h"
#include "engine/render/compositing_weights_tile.h"
#include "engine/render/instance_pose.h"
#include "engine/render/raster_frame.h"
#include "engine/render/raster_tile.h"
#include "engine/render/splat_projection.h"

namespace pf {
namespace {

using raster::kTile;
using raster::kTilePixels;

using Splat = raster::SplatGeometry;

// How many splats ahead the binning prefetches.
constexpr uint64_t kPrefetchAhead = weights_tile::kPrefetchAhead;

// Whether to record with the AVX2 build of the tile loop: where the CPU has
// it and the render's tile kernel is not the baseline (the same bits either
// way; PF_RENDER_KERNEL=baseline picks the baseline).
bool UseAvx2() {
#if defined(PF_RENDER_HAVE_AVX2_KERNEL)
  static const bool avx2 = __builtin_cpu_supports("avx2");
  return avx2 && std::strcmp(raster::TileKernelName(), "baseline") != 0;
#else
  return false;
#endif
}

// The camera as the projection reads it, and per owner (0 background, k
// instance k) the camera-from-owner transform: row-major r, then t.
struct ViewFrame : raster::ProjectionCamera {
  std::vector<float> camera_from_owner;  // [K+1, 12]
  // A rolling-shutter camera's frame as the rasterizer sets it up (its
  // projection then the rasterizer's: ProjectSplatAtItsLine).
  std::optional<raster::RenderFrame> rolling;
};

bool ProjectSplat(const GaussianScene& scene, const ViewFrame& frame, size_t i, Splat* out) {
  if (frame.rolling.has_value()) {
    if (!frame.rolling->owner_live[scene.owners[i]]) return false;
    return raster::ProjectSplatAtItsLine(scene, i, *frame.rolling, out);
  }
  const float* r = &frame.camera_from_owner[12 * scene.owners[i]];
  return raster::ProjectSplatGeometry(scene, i, frame, r, r + 9, out);
}

}  // namespace

absl::StatusOr<CompositingWeights> ComputeCompositingWeights(const GaussianScene& scene,
                                                             const RenderCamera& camera,
                                                             int64_t timestamp_us,
                                                             const WeightOptions& options) {
  const CameraModel& model = camera.model;
  if (model.width() <= 0 || model.height() <= 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("camera: image size ", model.width(), "x", model.height(), " has no pixels"));
  }
  if (absl::Status status = CheckRenderable(scene); !status.ok()) return status;
  if (options.omitted_colours && scene.num_channels < 3) {
    return absl::InvalidArgumentError(absl::StrCat(
        "omitted_colours: needs RGB in feature channels 0-2, the scene has ", scene.num_channels));
  }
  if (options.pixel_stride < 1) {
    return absl::InvalidArgumentError(
        absl::StrCat("pixel_stride: must be at least 1, got ", options.pixel_stride));
  }

  ViewFrame frame;
  raster::SetUpProjectionCamera(
      model, options.near_plane,
      scene.fade_span.Clamp(
          static_cast<float>(static_cast<double>(timestamp_us - scene.time_origin_us) * 1e-6)),
      &frame);
  const size_t num_owners = scene.instances.size() + 1;
  const Rigid camera_from_world = camera.world_from_camera.Inverse();
  frame.camera_from_owner.resize(12 * num_owners);
  for (size_t k = 0; k < num_owners; ++k) {
    const Rigid world_from_owner =
        k == 0 ? Rigid{} : InstancePoseAt(scene.instances[k - 1].boxes, timestamp_us);
    const Rigid x = camera_from_world * world_from_owner;
    float* f = &frame.camera_from_owner[12 * k];
    for (int a = 0; a < 3; ++a) {
      for (int b = 0; b < 3; ++b) f[3 * a + b] = static_cast<float>(x.rotation.m[a][b]);
      f[9 + a] = static_cast<float>(x.translation[a]);
    }
  }

  if (camera.rolling_shutter.has_value()) {
    frame.rolling.emplace();
    if (absl::Status status =
            raster::SetUpRenderFrame(scene.instances, scene.time_origin_us, scene.fade_span, camera,
                                     timestamp_us, {}, options.near_plane, &*frame.rolling);
        !status.ok()) {
      return status;
    }
  }

  // Project; order the visible Gaussians by (depth, index) as the
  // rasterizer's stable sort does: rank k is visible[uint32_t(keys[k])].
  const size_t n = scene.size();
  std::vector<Splat> visible;
  std::vector<uint32_t> visible_index;
  std::vector<uint64_t> keys;
  std::vector<float> visible_colour;  // [visible, 3] with omitted_colours.
  visible.reserve(n);
  visible_index.reserve(n);
  keys.reserve(n);
  for (size_t i = 0; i < n; ++i) {
    Splat splat;
    if (!ProjectSplat(scene, frame, i, &splat)) continue;
    const uint32_t depth_bits =
        raster::SortDepthBits(splat.depth, static_cast<uint32_t>(i), scene.order_band);
    keys.push_back((static_cast<uint64_t>(depth_bits) << 32) | visible.size());
    visible.push_back(splat);
    visible_index.push_back(static_cast<uint32_t>(i));
    if (options.omitted_colours) {
      const float* rgb = &scene.features[i * static_cast<size_t>(scene.num_channels)];
      visible_colour.insert(visible_colour.end(), rgb, rgb + 3);
    }
  }
  {
    // Visible indices rise with i: sorting by depth bits alone, stably, is
    // the (depth, index) order.
    std::vector<uint64_t> buffer;
    raster::RadixSortByHighWord(&keys, &buffer);
  }

  // Bin into the tiles the ellipse touches (the rasterizer's test): each
  // tile's list holds visible indices in rank order.
  const int tiles_x = (frame.width + kTile - 1) / kTile;
  const int tiles_y = (frame.height + kTile - 1) / kTile;
  const size_t num_tiles = static_cast<size_t>(tiles_x) * tiles_y;
  std::vector<uint64_t> tile_begin(num_tiles + 1, 0);
  auto for_each_tile = [&](const Splat& g, auto&& body) {
    raster::VisitTiles(g.mx, g.my, g.ca, g.cb, g.cc, g.span_d2, g.ext_x, g.ext_y, frame.width,
                       frame.height, tiles_x, [&](uint32_t t) { body(static_cast<size_t>(t)); });
  };
  for (const Splat& splat : visible) for_each_tile(splat, [&](size_t t) { ++tile_begin[t + 1]; });
  for (size_t t = 0; t < num_tiles; ++t) tile_begin[t + 1] += tile_begin[t];
  std::vector<uint32_t> tile_lists(tile_begin[num_tiles]);
  {
    std::vector<uint64_t> cursor(tile_begin.begin(), tile_begin.end() - 1);
    for (size_t k = 0; k < keys.size(); ++k) {
      // Rank order reads `visible` all over: ask for one ahead.
      if (k + kPrefetchAhead < keys.size())
        __builtin_prefetch(&visible[static_cast<uint32_t>(keys[k + kPrefetchAhead])]);
      const uint32_t i = static_cast<uint32_t>(keys[k]);
      for_each_tile(visible[i], [&](size_t t) { tile_lists[cursor[t]++] = i; });
    }
  }
  keys = std::vector<uint64_t>();

  // Composite tile by tile; each tile's entries are regrouped by pixel and
  // stored with their slots in the tile's table. Local indices go to the
  // Gaussians in the order of their first entry (CompositingWeights::gaussians).
  CompositingWeights out;
  out.width = frame.width;
  out.height = frame.height;
  out.pixel_stride = options.pixel_stride;
  const size_t pixels = static_cast<size_t>(frame.width) * frame.height;
  out.pixel_begin.assign(pixels, 0);
  out.pixel_count.assign(pixels, 0);
  out.pixel_table.assign(pixels, 0);
  out.table_begin.reserve(static_cast<size_t>(tiles_x) * tiles_y + 1);
  out.alpha.assign(pixels, 0.f);
  std::vector<weights_tile::Entry> tile_entries, by_pixel;
  if (options.omitted_colours) out.omitted.assign(3 * pixels, 0.f);
  // Per visible Gaussian: its local index, and the table it last got a
  // slot in, and that slot.
  std::vector<uint32_t> to_local(visible.size(), UINT32_MAX);
  std::vector<uint32_t> table_of(visible.size(), UINT32_MAX);
  std::vector<uint16_t> slot_of(visible.size(), 0);
  auto start_table = [&out] {
    out.table_begin.push_back(static_cast<uint32_t>(out.table.size()));
    return static_cast<uint32_t>(out.table_begin.size() - 1);
  };
  constexpr size_t kTableSlots = size_t{1} << 16;
  constexpr float kWeightSteps = 65535.f;  // 1 / CompositingWeights::kWeightStep.
  // The tile's transmittance, omitted colours (CompositingWeights::omitted)
  // per channel, and -1 for its pixels on the lattice (pixel_stride), else 0.
  alignas(32) float trans[weights_tile::kPadded];
  alignas(32) float omitted[3][weights_tile::kPadded];
  alignas(32) int32_t recorded[weights_tile::kPadded] = {};
  uint32_t counts[kTilePixels];
  uint32_t cursor[kTilePixels];
  const bool wide = UseAvx2();
  weights_tile::Tile tile;
  tile.visible = visible.data();
  tile.visible_colour = options.omitted_colours ? visible_colour.data() : nullptr;
  tile.min_weight = options.min_weight;
  tile.trans = trans;
  tile.recorded = recorded;
  tile.omitted = omitted;
  tile.entries = &tile_entries;
  for (int ty = 0; ty < tiles_y; ++ty) {
    for (int tx = 0; tx < tiles_x; ++tx) {
      const size_t t = static_cast<size_t>(ty) * tiles_x + tx;
      const int x_begin = tx * kTile, y_begin = ty * kTile;
      const int x_end = std::min(x_begin + kTile, frame.width);
      const int y_end = std::min(y_begin + kTile, frame.height);
      std::fill(trans, trans + weights_tile::kPadded, 1.f);
      for (int row = y_begin; row < y_end; ++row) {
        for (int col = x_begin; col < x_end; ++col) {
          recorded[(row - y_begin) * kTile + (col - x_begin)] =
              OnPixelLattice(col, row, options.pixel_stride) ? -1 : 0;
        }
      }
      tile_entries.clear();
      if (options.omitted_colours) std::memset(omitted, 0, sizeof(omitted));
      tile.x_begin = x_begin;
      tile.y_begin = y_begin;
      tile.x_end = x_end;
      tile.y_end = y_end;
      tile.list = tile_lists.data() + tile_begin[t];
      tile.list_size = tile_begin[t + 1] - tile_begin[t];
#if defined(PF_RENDER_HAVE_AVX2_KERNEL)
      if (wide) {
        RecordTileAvx2(tile);
      } else {
        RecordTileLanes<4>(tile);
      }
#else
      RecordTileLanes<4>(tile);
#endif
      // Regroup by pixel (stable: front to back within a pixel).
      std::fill(counts, counts + kTilePixels, 0u);
      for (const weights_tile::Entry& e : tile_entries) ++counts[e.pixel];
      uint32_t start = 0;
      for (int p = 0; p < kTilePixels; ++p) {
        cursor[p] = start;
        start += counts[p];
      }
      by_pixel.resize(tile_entries.size());
      for (const weights_tile::Entry& e : tile_entries) by_pixel[cursor[e.pixel]++] = e;
      // Pixel by pixel: a table per tile, another where the tile's
      // Gaussians would pass kTableSlots.
      uint32_t table_id = start_table();
      size_t table_begin = out.table.size();
      size_t next = 0;  // Into by_pixel.
      for (int p = 0; p < kTilePixels; ++p) {
        const int x = x_begin + p % kTile, y = y_begin + p / kTile;
        if (x >= x_end || y >= y_end) continue;
        const size_t pixel = static_cast<size_t>(y) * frame.width + x;
        if (out.table.size() - table_begin + counts[p] > kTableSlots) {
          table_id = start_table();
          table_begin = out.table.size();
        }
        if (out.pairs.size() + counts[p] > UINT32_MAX || counts[p] > UINT16_MAX) {
          return absl::InvalidArgumentError(
              absl::StrCat("camera: pixel (", x, ", ", y, ") would pass a view's ", UINT32_MAX,
                           " pairs or a pixel's ", UINT16_MAX, " (it has ", counts[p],
                           "); render fewer pixels"));
        }
        out.pixel_begin[pixel] = static_cast<uint32_t>(out.pairs.size());
        out.pixel_count[pixel] = static_cast<uint16_t>(counts[p]);
        out.pixel_table[pixel] = table_id;
        out.alpha[pixel] = 1.f - trans[p];
        if (options.omitted_colours) {
          for (int c = 0; c < 3; ++c) out.omitted[3 * pixel + c] = omitted[c][p];
        }
        for (const size_t end = next + counts[p]; next < end; ++next) {
          const weights_tile::Entry& e = by_pixel[next];
          if (table_of[e.gaussian] != table_id) {
            table_of[e.gaussian] = table_id;
            slot_of[e.gaussian] = static_cast<uint16_t>(out.table.size() - table_begin);
            uint32_t& local = to_local[e.gaussian];
            if (local == UINT32_MAX) {
              local = static_cast<uint32_t>(out.gaussians.size());
              out.gaussians.push_back(visible_index[e.gaussian]);
            }
            out.table.push_back(local);
          }
          // Rounded to the nearest step (weights are in [0, 0.99]).
          out.pairs.push_back(
              {slot_of[e.gaussian], static_cast<uint16_t>(e.weight * kWeightSteps + 0.5f)});
        }
      }
    }
  }
  if (out.table.size() > UINT32_MAX) {
    return absl::InvalidArgumentError(
        absl::StrCat("camera: ", out.table.size(), " table slots pass 2^32; render fewer pixels"));
  }
  start_table();  // The end of the last.

  if (options.local_coords) {
    out.local_frames.resize(6 * out.gaussians.size());
    for (size_t k = 0; k < visible.size(); ++k) {
      const uint32_t l = to_local[k];
      if (l == UINT32_MAX) continue;
      const Splat& g = visible[k];
      float* f = &out.local_frames[6 * static_cast<size_t>(l)];
      f[0] = g.mx;
      f[1] = g.my;
      f[2] = g.ux;
      f[3] = g.uy;
      f[4] = g.vx;
      f[5] = g.vy;
    }
  }
  return out;
}

namespace {

// The two products at one pixel p, with the channel count fixed at compile
// time when it is the common 3 (kChannels = 0: `channels` at run time):
// dst = (A c)_p, and out += (row p of A)^T r.
template <int kChannels>
inline void CompositePixel(const CompositingWeights& a, size_t p, const float* colours,
                           int channels, float* dst) {
  if constexpr (kChannels > 0) channels = kChannels;
  for (int c = 0; c < channels; ++c) dst[c] = 0.f;
  const uint64_t begin = a.pixel_begin[p], end = begin + a.pixel_count[p];
  const uint32_t* table = a.PixelTable(p);
  for (uint64_t e = begin; e < end; ++e) {
    const float w = a.Weight(e);
    const float* src = colours + static_cast<size_t>(table[a.pairs[e].slot]) * channels;
    for (int c = 0; c < channels; ++c) dst[c] += w * src[c];
  }
}

template <int kChannels>
inline void AccumulatePixel(const CompositingWeights& a, size_t p, const float* r, int channels,
                            float* out) {
  if constexpr (kChannels > 0) channels = kChannels;
  const uint64_t begin = a.pixel_begin[p], end = begin + a.pixel_count[p];
  const uint32_t* table = a.PixelTable(p);
  for (uint64_t e = begin; e < end; ++e) {
    const float w = a.Weight(e);
    float* dst = out + static_cast<size_t>(table[a.pairs[e].slot]) * channels;
    for (int c = 0; c < channels; ++c) dst[c] += w * r[c];
  }
}

// The same for colours with gradients: 9 parameters per Gaussian.
inline void CompositePixelTextured(const CompositingWeights& a, size_t p, const float* params,
                                   float* dst) {
  dst[0] = dst[1] = dst[2] = 0.f;
  float px, py;
  a.PixelCentre(p, &px, &py);
  const uint64_t begin = a.pixel_begin[p], end = begin + a.pixel_count[p];
  const uint32_t* table = a.PixelTable(p);
  for (uint64_t e = begin; e < end; ++e) {
    const uint32_t local = table[a.pairs[e].slot];
    float u, v;
    a.LocalCoords(local, px, py, &u, &v);
    const float w = a.Weight(e), wu = w * u, wv = w * v;
    const float* src = params + static_cast<size_t>(local) * 9;
    for (int c = 0; c < 3; ++c)
      dst[c] += w * src[3 * c] + wu * src[3 * c + 1] + wv * src[3 * c + 2];
  }
}

inline void AccumulatePixelTextured(const CompositingWeights& a, size_t p, const float* r,
                                    float* out) {
  float px, py;
  a.PixelCentre(p, &px, &py);
  const uint64_t begin = a.pixel_begin[p], end = begin + a.pixel_count[p];
  const uint32_t* table = a.PixelTable(p);
  for (uint64_t e = begin; e < end; ++e) {
    const uint32_t local = table[a.pairs[e].slot];
    float u, v;
    a.LocalCoords(local, px, py, &u, &v);
    const float w = a.Weight(e), wu = w * u, wv = w * v;
    float* dst = out + static_cast<size_t>(local) * 9;
    for (int c = 0; c < 3; ++c) {
      dst[3 * c] += w * r[c];
      dst[3 * c + 1] += wu * r[c];
      dst[3 * c + 2] += wv * r[c];
    }
  }
}

template <int kChannels>
void CompositeImpl(const CompositingWeights& a, const float* colours, int channels, float* image) {
  if constexpr (kChannels > 0) channels = kChannels;
  for (size_t p = 0; p < a.pixel_begin.size(); ++p)
    CompositePixel<kChannels>(a, p, colours, channels, image + p * channels);
}

template <int kChannels>
void AccumulateTransposedImpl(const CompositingWeights& a, const float* residual, int channels,
                              float* out) {
  if constexpr (kChannels > 0) channels = kChannels;
  for (size_t p = 0; p < a.pixel_begin.size(); ++p)
    AccumulatePixel<kChannels>(a, p, residual + p * channels, channels, out);
}

}  // namespace

void CompositeTextured(const CompositingWeights& a, const float* params, float* image) {
  for (size_t p = 0; p < a.pixel_begin.size(); ++p)
    CompositePixelTextured(a, p, params, image + p * 3);
}

void AccumulateTransposedTextured(const CompositingWeights& a, const float* residual, float* out) {
  for (size_t p = 0; p < a.pixel_begin.size(); ++p)
    AccumulatePixelTextured(a, p, residual + p * 3, out);
}

void AccumulateNormal(const CompositingWeights& a, const std::vector<uint8_t>& mask, const float* x,
                      float* out) {
  if (!a.has_local_coords()) {
    for (size_t p = 0; p < a.pixel_begin.size(); ++p) {
      if (!mask[p]) continue;
      float v[3];
      CompositePixel<3>(a, p, x, 3, v);
      AccumulatePixel<3>(a, p, v, 3, out);
    }
    return;
  }
  // Room for the largest table's Gaussians (ForEachMaskedPixelByTable).
  uint32_t largest = 0;
  for (size_t t = 0; t + 1 < a.table_begin.size(); ++t)
    largest = std::max(largest, a.TableSize(static_cast<uint32_t>(t)));
  std::vector<float> gathered(24 * size_t(largest));
  const TableScratch scratch{gathered.data(), gathered.data() + 9 * size_t(largest),
                             gathered.data() + 15 * size_t(largest)};
#if defined(PF_RENDER_HAVE_AVX2_KERNEL)
  if (UseAvx2()) {
    AccumulateNormalTexturedAvx2(a, mask, x, out, scratch);
    return;
  }
#endif
  // The baseline. Per pixel, (A x)_p then out += (row p of A)^T (A x)_p,
  // with each entry's (w, w u, w v) worked out once for both and the three
  // channels in 4-wide vectors: channel c's (colour, g_u, g_v) are
  // params[3c .. 3c+2].
  typedef float V4 __attribute__((vector_size(16)));
  auto load = [](const float* p) {
    V4 v;
    std::memcpy(&v, p, sizeof(v));
    return v;
  };
  auto store = [](float* p, V4 v) { std::memcpy(p, &v, sizeof(v)); };
  auto sum = [](V4 v) { return (v[0] + v[1]) + (v[2] + v[3]); };
  struct Entry {
    float* out;
    float w, wu, wv;
  };
  std::vector<Entry> row;
  ForEachMaskedPixelByTable(
      a, mask, x, out, scratch, [&](uint64_t begin, uint64_t count, float px, float py) {
        if (row.size() < count) row.resize(count);
        // Channels 0 and 1 from params[0..3] and [3..6] under (w, wu, wv,
        // 0); channel 2 from params[5..8] under (0, w, wu, wv), so no load
        // passes the Gaussian's 9 floats.
        V4 c0 = {0, 0, 0, 0}, c1 = c0, c2 = c0;
        for (uint64_t k = 0; k < count; ++k) {
          const auto [w, wu, wv, offset] = TexturedEntryAt(a, scratch, begin + k, px, py);
          const float* src = scratch.x + offset;
          const V4 lead = {w, wu, wv, 0.f}, tail = {0.f, w, wu, wv};
          c0 += lead * load(src);
          c1 += lead * load(src + 3);
          c2 += tail * load(src + 5);
          row[k] = {scratch.out + offset, w, wu, wv};
        }
        const float v0 = sum(c0), v1 = sum(c1), v2 = sum(c2);
        for (uint64_t k = 0; k < count; ++k) {
          const Entry& entry = row[k];
          float* dst = entry.out;
          const V4 first = {entry.w * v0, entry.wu * v0, entry.wv * v0, entry.w * v1};
          const V4 second = {entry.wu * v1, entry.wv * v1, entry.w * v2, entry.wu * v2};
          store(dst, load(dst) + first);
          store(dst + 4, load(dst + 4) + second);
          dst[8] += entry.wv * v2;
        }
      });
}

void CompositingWeights::Unpack(std::vector<uint32_t>* local, std::vector<float>* weights) const {
  local->resize(pairs.size());
  weights->resize(pairs.size());
  for (size_t p = 0; p < pixel_begin.size(); ++p) {
    const uint32_t* t = PixelTable(p);
    for (uint64_t e = pixel_begin[p]; e < pixel_begin[p] + pixel_count[p]; ++e) {
      (*local)[e] = t[pairs[e].slot];
      (*weights)[e] = Weight(e);
    }
  }
}

void Composite(const CompositingWeights& a, const float* colours, int channels, float* image) {
  if (channels == 3) {
    CompositeImpl<3>(a, colours, 3, image);
  } else {
    CompositeImpl<0>(a, colours, channels, image);
  }
}

void AccumulateTransposed(const CompositingWeights& a, const float* residual, int channels,
                          float* out) {
  if (channels == 3) {
    AccumulateTransposedImpl<3>(a, residual, 3, out);
  } else {
    AccumulateTransposedImpl<0>(a, residual, channels, out);
  }
}

}  // namespace pf
