// Least-squares refinement of Gaussian colours against the context images:
// preconditioned conjugate gradients over the recorded compositing weights.
#include "engine/recon/colour_refinement.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <mutex>

#include "absl/strings/str_cat.h"
#include "common/elapsed.h"
#include "common/memory_info.h"
#include "common/status_macros.h"
#include "common/thread_pool.h"
#include "engine/recon/colour_fit_blocks.h"
#include "engine/recon/cuda_colour_fit.h"
#include "engine/recon/gaussian_decoder.h"
#include "engine/render/compositing_weights.h"
#include "engine/render/raster_tile.h"

namespace pf {
namespace {

using Channels = ChannelSums;
using colour_fit::kMinTransmittance;
using colour_fit::kSums;
using colour_fit::PreconditionBlock;

// Added to every Gaussian's data weight (its sum of squared compositing
// weights) before the relative prior is taken, so that a Gaussian no fitted
// pixel sees still has a positive prior and keeps its fused colour.
constexpr float kPriorFloor = 1e-3f;

// The data weight a colour's prior is relative to: the geometric mean of
// the Gaussian's own data weight `seen` (sum of w_ip^2) and the weight it
// would have with nothing in front of it, `unoccluded` (sum of alpha_ip^2,
// at least `seen`). Fully visible, that is `seen`; a Gaussian that its
// context views see only through what lies in front of it (transmittance
// T) is held 1 / T times harder, relative to its data, so the few dim
// pixels it reaches do not push its colour out of range: the road beside a
// car in seed 2 came out as (1.5, 0.8, -0.5) and showed where the car moved
// on.
float UnoccludedPrior(float seen, float unoccluded) {
  return std::sqrt(seen * std::max(seen, unoccluded));
}

// The prior weight of hidden Gaussians, relative like prior_weight: large
// enough that the fit leaves their colour as it is.
constexpr float kHiddenPrior = 1e4f;

// One context view in the fit: its compositing matrix and what it is fitted
// to, with pixels under min_alpha zeroed out of both sides (the mask M).
struct FitView {
  CompositingWeights a;
  std::vector<uint8_t> fitted;  // [H * W] 1 where alpha >= min_alpha.
  // [H * W, 3] the image less what the entries under min_weight add with
  // the decoded colours (CompositingWeights::omitted): those entries are
  // held at the decoded colours, so A x fits the rest.
  std::vector<float> target;
};

// Per-view scratch: colours gathered to local order, the view's image-sized
// buffer and the view's share of A^T (...), local order.
struct ViewScratch {
  std::vector<float> local_in;
  std::vector<float> pixels;
  std::vector<float> local_out;
};

// ViewScratch::local_in and ::pixels for the tasks running at once: a task
// leases one pair and lends it to the scratch of each view it works on.
class WorkingBuffers {
 public:
  struct Pair {
    std::vector<float> local_in, pixels;
  };
  class Lease {
   public:
    explicit Lease(WorkingBuffers* owner) : owner_(owner), pair_(owner->Acquire()) {}
    ~Lease() { owner_->Release(std::move(pair_)); }
    Lease(const Lease&) = delete;
    Lease& operator=(const Lease&) = delete;
    void LendTo(ViewScratch* s) {
      s->local_in.swap(pair_->local_in);
      s->pixels.swap(pair_->pixels);
    }
    void TakeBack(ViewScratch* s) { LendTo(s); }

   private:
    WorkingBuffers* owner_;
    std::unique_ptr<Pair> pair_;
  };

 private:
  std::unique_ptr<Pair> Acquire() {
    std::lock_guard<std::mutex> lock(mutex_);
    if (free_.empty()) return std::make_unique<Pair>();
    std::unique_ptr<Pair> pair = std::move(free_.back());
    free_.pop_back();
    return pair;
  }
  void Release(std::unique_ptr<Pair> pair) {
    std::lock_guard<std::mutex> lock(mutex_);
    free_.push_back(std::move(pair));
  }
  std::mutex mutex_;
  std::vector<std::unique_ptr<Pair>> free_;
};

// The fit's unknowns per Gaussian: per RGB channel the colour, and with
// colour gradients also (g_u, g_v): [N, 3, K], K = 1 or 3.
struct Layout {
  int k = 1;
  int per_gaussian() const { return 3 * k; }
};

// image = A x and out += A^T r for the fit's unknowns: flat colours, or
// colours with gradients (then the weights carry local coordinates).
void Apply(const CompositingWeights& a, const float* x, float* image) {
  if (!a.has_local_coords()) {
    Composite(a, x, 3, image);
  } else {
    CompositeTextured(a, x, image);
  }
}
void ApplyTransposed(const CompositingWeights& a, const float* r, float* out) {
  if (!a.has_local_coords()) {
    AccumulateTransposed(a, r, 3, out);
  } else {
    AccumulateTransposedTextured(a, r, out);
  }
}

// Writes the inverse of the symmetric matrix [[a, b, c], [b, d, e], [c, e,
// f]] to `out` as (00, 01, 02, 11, 12, 22); the inverse of its diagonal
// where it is near singular.
void InvertSymmetric3(double a, double b, double c, double d, double e, double f, float* out) {
  const double m00 = d * f - e * e, m01 = c * e - b * f, m02 = b * e - c * d;
  const double det = a * m00 + b * m01 + c * m02;
  if (!(det > 1e-9 * a * d * f)) {
    out[0] = static_cast<float>(1 / a);
    out[1] = out[2] = out[4] = 0.f;
    out[3] = static_cast<float>(1 / d);
    out[5] = static_cast<float>(1 / f);
    return;
  }
  out[0] = static_cast<float>(m00 / det);
  out[1] = static_cast<float>(m01 / det);
  out[2] = static_cast<float>(m02 / det);
  out[3] = static_cast<float>((a * f - c * c) / det);
  out[4] = static_cast<float>((b * c - a * e) / det);
  out[5] = static_cast<float>((a * d - b * b) / det);
}

// Adds each Gaussian's colour_fit::kSums sums over one view's fitted pixels
// to `out` (local order).
void AccumulateSums(const CompositingWeights& a, const std::vector<uint8_t>& fitted, float* out) {
  const bool textured = a.has_local_coords();
  for (size_t p = 0; p < fitted.size(); ++p) {
    if (!fitted[p]) continue;
    float px, py;
    a.PixelCentre(p, &px, &py);
    float in_front = 0.f;
    const uint32_t* table = a.PixelTable(p);
    for (uint64_t k = a.pixel_begin[p]; k < a.pixel_begin[p] + a.pixel_count[p]; ++k) {
      const float w = a.Weight(k);
      const uint32_t local = table[a.pairs[k].slot];
      float u = 0.f, v = 0.f;
      if (textured) a.LocalCoords(local, px, py, &u, &v);
      const float alpha = w / std::max(kMinTransmittance, 1.f - in_front);
      in_front += w;
      const float ww = w * w;
      float* d = out + kSums * size_t(local);
      d[0] += ww;
      d[1] += ww * u * u;
      d[2] += ww * v * v;
      d[3] += ww * u;
      d[4] += ww * v;
      d[5] += ww * u * v;
      d[6] += alpha * alpha;
    }
  }
}

// Sum of squares of the masked residual image - A x of one view (x already
// gathered into scratch->local_in), per channel; leaves the masked residual
// in scratch->pixels.
Channels Residual(const FitView& view, ViewScratch* scratch) {
  const size_t num_pixels = view.fitted.size();
  scratch->pixels.resize(3 * num_pixels);
  Apply(view.a, scratch->local_in.data(), scratch->pixels.data());
  Channels sum{0, 0, 0};
  for (size_t p = 0; p < num_pixels; ++p) {
    for (int c = 0; c < 3; ++c) {
      float& r = scratch->pixels[3 * p + c];
      r = view.fitted[p] ? view.target[3 * p + c] - r : 0.f;
      sum[c] += double(r) * r;
    }
  }
  return sum;
}

// Copies the entries of `global` ([N, 3], scene order) that `view` sees into
// scratch->local_in (local order).
void Gather(const FitView& view, const Layout& layout, const std::vector<float>& global,
            ViewScratch* scratch) {
  const size_t m = view.a.gaussians.size();
  const int per = layout.per_gaussian();
  scratch->local_in.resize(per * m);
  for (size_t k = 0; k < m; ++k)
    for (int c = 0; c < per; ++c)
      scratch->local_in[per * k + c] = global[per * size_t(view.a.gaussians[k]) + c];
}

// Adds the local_out of views [first, first + scratch.size()) into `global`
// (views in order, so the sums do not depend on thread timing) and zeroes
// it for the next batch.
void Scatter(const std::vector<FitView>& views, size_t first, int per,
             std::vector<ViewScratch>* scratch, std::vector<float>* global) {
  for (size_t slot = 0; slot < scratch->size() && first + slot < views.size(); ++slot) {
    const std::vector<uint32_t>& ids = views[first + slot].a.gaussians;
    std::vector<float>& local = (*scratch)[slot].local_out;
    DefaultThreadPool().ParallelFor(0, static_cast<int64_t>(ids.size()), 16384,
                                    [&](int64_t b, int64_t e) {
                                      for (int64_t k = b; k < e; ++k) {
                                        for (int c = 0; c < per; ++c) {
                                          float& value = local[per * k + c];
                                          (*global)[per * size_t(ids[k]) + c] += value;
                                          value = 0.f;
                                        }
                                      }
                                    });
  }
}

// Recording stops early once the views counted (kProjectionViews at least,
// or all) put the whole clip on course for this many times the bound.
constexpr double kProjectedOverBudget = 1.25;
constexpr int64_t kProjectionViews = 6;
// Units (kWeightUnitBytes) of a Gaussian's screen frame in a view's
// weights, with gradients: 6 floats.
constexpr int64_t kFrameUnits = 6;
// RefinementOptions::max_pixel_stride at most (CountLattices' bits).
constexpr int kMaxPixelStride = 7;

// Every view's weights (one view per task) and fitted pixels, recorded at
// 1 pixel in `pixel_stride`; recording stops once the views together pass
// options.max_pairs units (kWeightUnitBytes: a unit per pair and per table
// slot, and with colour gradients kFrameUnits more per Gaussian in view,
// its screen frame).
struct RecordedViews {
  std::vector<FitView> fit;
  bool over_budget = false;
  int64_t units = 0;          // Of the views counted.
  int64_t frame_units = 0;    // Of which screen frames.
  int64_t counted_views = 0;  // Views whose units are counted.
  // Recorded on every pixel (stride 1): of the views counted, the entries
  // and table slots, and the contributing Gaussians (screen frames), on the
  // lattice of each stride k in [1, max_pixel_stride], at [k]; empty
  // otherwise.
  std::vector<int64_t> entries_at;
  std::vector<int64_t> frames_at;
};

// Adds what `a` (recorded on every pixel) would hold on the lattice of each
// stride k in [1, entries_at->size()) to (*entries_at)[k] (entries and table
// slots: the tables of a tile's pixels on the lattice) and (*frames_at)[k]
// (contributing Gaussians).
void CountLattices(const CompositingWeights& a, std::vector<int64_t>* entries_at,
                   std::vector<int64_t>* frames_at) {
  const int max_stride = static_cast<int>(entries_at->size()) - 1;
  // Bit k: on stride k's lattice, in the view and in the table at work.
  std::vector<uint8_t> seen(a.gaussians.size(), 0), in_table(a.gaussians.size(), 0);
  std::vector<uint32_t> table_members;
  auto close_table = [&] {
    for (uint32_t l : table_members) {
      for (int k = 1; k <= max_stride; ++k) (*entries_at)[k] += (in_table[l] >> k) & 1;
      in_table[l] = 0;
    }
    table_members.clear();
  };
  constexpr int kTile = raster::kTile;  // The tiles CompositingWeights stores its pixels by.
  uint32_t table_at = UINT32_MAX;
  for (int tile_y = 0; tile_y < a.height; tile_y += kTile) {
    for (int tile_x = 0; tile_x < a.width; tile_x += kTile) {
      for (int y = tile_y; y < std::min(a.height, tile_y + kTile); ++y) {
        for (int x = tile_x; x < std::min(a.width, tile_x + kTile); ++x) {
          const size_t p = static_cast<size_t>(y) * a.width + x;
          if (a.pixel_table[p] != table_at) {
            close_table();
            table_at = a.pixel_table[p];
          }
          uint8_t strides = 0;
          for (int k = 1; k <= max_stride; ++k) {
            if (!OnPixelLattice(x, y, k)) continue;
            strides |= uint8_t(1u << k);
            (*entries_at)[k] += a.pixel_count[p];
          }
          const uint32_t* table = a.PixelTable(p);
          for (uint64_t e = a.pixel_begin[p]; e < a.pixel_begin[p] + a.pixel_count[p]; ++e) {
            const uint32_t l = table[a.pairs[e].slot];
            seen[l] |= strides;
            if (in_table[l] == 0) table_members.push_back(l);
            in_table[l] |= strides;
          }
        }
      }
    }
  }
  close_table();
  for (uint8_t strides : seen)
    for (int k = 1; k <= max_stride; ++k) (*frames_at)[k] += (strides >> k) & 1;
}

// The smallest stride in [first, max_pixel_stride] at which the whole
// clip's weights, estimated from the views a stride-1 recording counted, fit
// in `room` units, with screen frames or without; 0 if none does.
int StrideThatFits(const RecordedViews& recorded, int64_t num_views, double room, bool gradients,
                   size_t first) {
  const double scale = double(num_views) / double(std::max<int64_t>(1, recorded.counted_views));
  for (size_t k = first; k < recorded.entries_at.size(); ++k) {
    const double units = double(recorded.entries_at[k]) +
                         (gradients ? double(kFrameUnits) * double(recorded.frames_at[k]) : 0.0);
    if (scale * units <= room) return static_cast<int>(k);
  }
  return 0;
}

absl::StatusOr<RecordedViews> RecordViews(const std::vector<ContextView>& views,
                                          const GaussianScene& scene,
                                          const RefinementOptions& options, bool gradients,
                                          int pixel_stride) {
  const int64_t num_views = static_cast<int64_t>(views.size());
  RecordedViews out;
  out.fit.resize(views.size());
  std::vector<absl::Status> errors(views.size());
  std::atomic<int64_t> units{0}, frame_units{0}, counted{0};
  std::atomic<bool> over_budget{false};
  // Before a stride is known (every pixel), each view's counts at the other
  // strides, so that one recording tells the stride that fits.
  const bool count_lattices = pixel_stride == 1 && options.max_pixel_stride > 1;
  std::mutex lattice_mutex;
  if (count_lattices) {
    out.entries_at.assign(options.max_pixel_stride + 1, 0);
    out.frames_at.assign(options.max_pixel_stride + 1, 0);
  }
  DefaultThreadPool().ParallelFor(0, num_views, 1, [&](int64_t b, int64_t e) {
    for (int64_t v = b; v < e; ++v) {
      if (over_budget.load()) break;
      const ContextView& view = views[v];
      WeightOptions weight_options;
      weight_options.min_weight = options.min_weight;
      weight_options.local_coords = gradients;
      weight_options.pixel_stride = pixel_stride;
      weight_options.omitted_colours = true;
      absl::StatusOr<CompositingWeights> a =
          ComputeCompositingWeights(scene, view.render_camera(), view.timestamp_us, weight_options);
      if (!a.ok()) {
        errors[v] = a.status();
        continue;
      }
      const int64_t frames =
          gradients ? kFrameUnits * static_cast<int64_t>(a->gaussians.size()) : 0;
      const int64_t cost = static_cast<int64_t>(a->entries() + a->table.size()) + frames;
      if (count_lattices) {
        std::vector<int64_t> entries_at(out.entries_at.size(), 0);
        std::vector<int64_t> frames_at(out.frames_at.size(), 0);
        CountLattices(*a, &entries_at, &frames_at);
        std::lock_guard<std::mutex> lock(lattice_mutex);
        for (size_t k = 0; k < entries_at.size(); ++k) {
          out.entries_at[k] += entries_at[k];
          out.frames_at[k] += frames_at[k];
        }
      }
      frame_units += frames;
      const int64_t views_counted = ++counted;
      const int64_t total = units.fetch_add(cost) + cost;
      // Over the bound, or on course for kProjectedOverBudget times it
      // after kProjectionViews views (a rig's cameras differ): the rest need
      // not be recorded to know.
      if (total > options.max_pairs || (views_counted >= std::min(num_views, kProjectionViews) &&
                                        double(total) * double(num_views) / double(views_counted) >
                                            kProjectedOverBudget * double(options.max_pairs))) {
        over_budget = true;
        break;
      }
      FitView& fit = out.fit[v];
      fit.a = *std::move(a);
      // The target in place of the omitted colours.
      fit.target = std::move(fit.a.omitted);
      for (size_t k = 0; k < fit.target.size(); ++k)
        fit.target[k] = view.rgb.pixels[k] - fit.target[k];
      fit.fitted.resize(fit.a.alpha.size());
      for (size_t p = 0; p < fit.fitted.size(); ++p)
        fit.fitted[p] = fit.a.alpha[p] >= options.min_alpha && !view.is_ego(p) && fit.a.Records(p);
      std::vector<float>().swap(fit.a.alpha);  // In `fitted` now.
    }
  });
  for (const absl::Status& error : errors) RETURN_IF_ERROR(error);
  out.over_budget = over_budget.load();
  out.units = units.load();
  out.frame_units = frame_units.load();
  out.counted_views = counted.load();
  if (out.over_budget) out.fit.clear();
  return out;
}

// The prior of each Gaussian's K unknowns of a channel, the same for the
// three channels ([N, K]: colour, and with gradients g_u, g_v), and the
// inverse of each Gaussian's block of A^T M A + Lambda
// (colour_fit::PreconditionBlock's layout).
struct Preconditioner {
  std::vector<float> prior;
  std::vector<float> inverse;
  // The prior of every unknown, [N, 3K] (the GPU solve's layout).
  std::vector<float> PerUnknown(size_t k) const {
    std::vector<float> out(3 * prior.size());
    for (size_t i = 0; i < prior.size() / k; ++i)
      for (size_t c = 0; c < 3; ++c)
        for (size_t j = 0; j < k; ++j) out[3 * k * i + k * c + j] = prior[k * i + j];
    return out;
  }
};

// Whether Gaussian i keeps its decoded colour (agreement channel 0: no
// context view observes it; RefinementOptions::keep_hidden).
bool HiddenGaussian(const GaussianScene& scene, const RefinementOptions& options, size_t i) {
  const int stride = scene.num_channels;
  return options.keep_hidden && stride > kAgreementChannel &&
         scene.features[i * stride + kAgreementChannel] <= 0.f;
}

// The prior of each Gaussian is relative to its own data weight (plus a
// floor for Gaussians no fitted pixel sees), so one prior_weight means the
// same for small pixel-aligned discs and large fused ones; with
// prior_from_unoccluded, to UnoccludedPrior of it.
// Hidden Gaussians keep their colour: the little weight they get where the
// surface in front is not quite opaque would only let them absorb its
// residuals. The gradients' prior pulls them to 0 (flat), relative in the
// same way.
// The preconditioner: per Gaussian, the inverse of its block of
// A^T M A + Lambda (1x1 for flat colours; 3x3, colour and its two
// gradients, with gradients), the same for the three channels. The colour
// and its gradients of one disc share every pixel, so their block is far
// from diagonal, and by the diagonal alone the fit converged slowly
// (docs/QUALITY.md, "The method as built"). `sums` is [N, kSums].
Preconditioner MakePreconditioner(const std::vector<float>& sums, const Layout& layout,
                                  const RefinementOptions& options, const GaussianScene& scene) {
  const size_t n = scene.size();
  const int per = layout.per_gaussian();
  const int kk = layout.k;
  const float lambda = static_cast<float>(options.prior_weight);
  const float lambda_gradient = static_cast<float>(options.gradient_prior_weight);
  Preconditioner out;
  out.prior.resize(kk * n);
  out.inverse.resize((kk == 3 ? 6 : 1) * n);
  for (size_t i = 0; i < n; ++i) {
    const float* sum = &sums[kSums * i];
    const bool hidden = HiddenGaussian(scene, options, i);
    const float data =
        hidden || !options.prior_from_unoccluded ? sum[0] : UnoccludedPrior(sum[0], sum[6]);
    const float prior_colour = (hidden ? kHiddenPrior : lambda) * (data + kPriorFloor);
    out.prior[kk * i] = prior_colour;
    if (kk == 1) {
      out.inverse[i] = 1.f / (sum[0] + prior_colour);
      continue;
    }
    const float gradient = hidden ? kHiddenPrior : lambda_gradient;
    const float prior_u = gradient * (sum[1] + kPriorFloor);
    const float prior_v = gradient * (sum[2] + kPriorFloor);
    out.prior[3 * i + 1] = prior_u;
    out.prior[3 * i + 2] = prior_v;
    InvertSymmetric3(sum[0] + prior_colour, sum[3], sum[4], sum[1] + prior_u, sum[5],
                     sum[2] + prior_v, &out.inverse[6 * i]);
  }
  return out;
}

// Clamps the solution `x` in place to the colour and gradient ranges and
// writes it to the scene (gradients are fitted here or not at all: flat
// colours drop old ones). Hidden Gaussians stay flat (their prior only
// nearly pins them).
void StoreColours(const Layout& layout, const RefinementOptions& options, std::vector<float>* x,
                  GaussianScene* scene) {
  const size_t n = scene->size();
  const int per = layout.per_gaussian();
  const int kk = layout.k;
  const int stride = scene->num_channels;
  if (kk == 3) {
    scene->colour_gradients.assign(6 * n, 0.f);
  } else {
    scene->colour_gradients.clear();
  }
  for (size_t i = 0; i < n; ++i) {
    const bool hidden = HiddenGaussian(*scene, options, i);
    for (int c = 0; c < 3; ++c) {
      float* xc = &(*x)[per * i + kk * c];
      xc[0] = std::clamp(xc[0], options.min_colour, options.max_colour);
      scene->features[i * stride + c] = xc[0];
      for (int g = 1; g < kk; ++g) {
        xc[g] = hidden ? 0.f : std::clamp(xc[g], -options.max_gradient, options.max_gradient);
        scene->colour_gradients[6 * i + 2 * c + g - 1] = xc[g];
      }
    }
  }
}

double Rmse(const Channels& sums, int64_t pixels) {
  return std::sqrt((sums[0] + sums[1] + sums[2]) / (3.0 * double(pixels)));
}

// The fit on the CPU: preconditioned conjugate gradients over the recorded
// weights, from x (the decoded colours) to the stored result.
void SolveOnCpu(std::vector<FitView>& fit, const Layout& layout, const RefinementOptions& options,
                GaussianScene* scene, std::vector<float>* x_out, RefinementStats* stats) {
  std::vector<float>& x = *x_out;
  const size_t n = scene->size();
  const int64_t num_views = static_cast<int64_t>(fit.size());
  const int per = layout.per_gaussian();
  const int kk = layout.k;
  // for_views runs `body(view, scratch)` for every view, a batch of
  // kViewsPerThread views per working thread at a time in parallel, and
  // adds each batch's local_out into `out` (zeroed first) unless it is
  // null: the scratch is held for one batch, not for every view, and the
  // sums run in view order whatever the batch.
  constexpr int64_t kViewsPerThread = 4;
  const int64_t batch =
      std::min<int64_t>(num_views, kViewsPerThread * (DefaultThreadPool().num_threads() + 1));
  std::vector<ViewScratch> scratch(batch);
  // Only local_out lives until the batch's Scatter(); local_in and pixels
  // are lent to each running task for its views (as many as run at once,
  // not one per view of the batch).
  WorkingBuffers working;
  auto for_views = [&](const auto& body, std::vector<float>* out, int width = 0) {
    if (width == 0) width = per;
    if (out != nullptr) out->assign(width * n, 0.f);
    for (int64_t first = 0; first < num_views; first += batch) {
      // local_out is zero as made, and Scatter() zeroes what a body adds.
      DefaultThreadPool().ParallelFor(
          first, std::min(num_views, first + batch), 1, [&](int64_t b, int64_t e) {
            WorkingBuffers::Lease lease(&working);
            for (int64_t v = b; v < e; ++v) {
              ViewScratch& slot = scratch[v - first];
              slot.local_out.resize(size_t(width) * fit[v].a.gaussians.size());
              lease.LendTo(&slot);
              body(fit[v], &slot);
              lease.TakeBack(&slot);
            }
          });
      if (out != nullptr) Scatter(fit, static_cast<size_t>(first), width, &scratch, out);
    }
  };
  std::vector<Channels> view_sums(fit.size());
  auto total = [&]() {
    Channels sum{0, 0, 0};
    for (const Channels& s : view_sums)
      for (int c = 0; c < 3; ++c) sum[c] += s[c];
    return sum;
  };

  // r = A^T M (I - A x), the negative gradient at x = c0 (where the prior
  // term is 0).
  std::vector<float> r;
  for_views(
      [&](const FitView& view, ViewScratch* s) {
        Gather(view, layout, x, s);
        view_sums[&view - fit.data()] = Residual(view, s);
        ApplyTransposed(view.a, s->pixels.data(), s->local_out.data());
      },
      &r);
  stats->rmse_before = Rmse(total(), stats->pixels);
  std::vector<float> sums;
  for_views([&](const FitView& view,
                ViewScratch* s) { AccumulateSums(view.a, view.fitted, s->local_out.data()); },
            &sums, kSums);
  const Preconditioner pre = MakePreconditioner(sums, layout, options, *scene);
  std::vector<float>().swap(sums);
  // Runs body(i, &sum) for every Gaussian i on the pool, in blocks of a
  // fixed size, and returns the per-channel sums it adds up: the blocks'
  // sums are added in block order, so they do not depend on the thread
  // count. The vector updates of an iteration are three such passes.
  constexpr int64_t kBlock = 16384;
  const int64_t num_blocks = (static_cast<int64_t>(n) + kBlock - 1) / kBlock;
  std::vector<Channels> block_sums(num_blocks);
  auto for_gaussians = [&](const auto& body) {
    DefaultThreadPool().ParallelFor(0, num_blocks, 1, [&](int64_t b, int64_t e) {
      for (int64_t block = b; block < e; ++block) {
        Channels sum{0, 0, 0};
        const size_t end = std::min(n, static_cast<size_t>(block + 1) * kBlock);
        for (size_t i = static_cast<size_t>(block) * kBlock; i < end; ++i) body(i, &sum);
        block_sums[block] = sum;
      }
    });
    Channels total{0, 0, 0};
    for (const Channels& sum : block_sums)
      for (int c = 0; c < 3; ++c) total[c] += sum[c];
    return total;
  };
  // z_i = (block i)^-1 r_i for Gaussian i.
  const size_t inverse_size = kk == 3 ? 6 : 1;
  auto precondition = [&](size_t i, const float* r, float* z) {
    PreconditionBlock(&pre.inverse[inverse_size * i], kk, r, z);
  };

  // Preconditioned conjugate gradients, the three channels side by side.
  // z = M^-1 r is worked out per Gaussian where it is needed, not stored.
  std::vector<float> p(per * n), q;
  Channels rz = for_gaussians([&](size_t i, Channels* sum) {
    const size_t k = per * i;
    float z[9];
    precondition(i, &r[k], z);
    for (int j = 0; j < per; ++j) {
      p[k + j] = z[j];
      (*sum)[j / kk] += double(r[k + j]) * z[j];
    }
  });
  for (int iteration = 0; iteration < options.iterations; ++iteration) {
    // q = (A^T M A + Lambda) p.
    for_views(
        [&](const FitView& view, ViewScratch* s) {
          Gather(view, layout, p, s);
          AccumulateNormal(view.a, view.fitted, s->local_in.data(), s->local_out.data());
        },
        &q);
    const Channels pq = for_gaussians([&](size_t i, Channels* sum) {
      const float* prior = &pre.prior[kk * i];
      for (int c = 0; c < 3; ++c) {
        for (int g = 0; g < kk; ++g) {
          const size_t k = per * i + kk * c + g;
          q[k] += prior[g] * p[k];
          (*sum)[c] += double(p[k]) * q[k];
        }
      }
    });
    float step[3];
    for (int c = 0; c < 3; ++c) step[c] = pq[c] > 0 ? static_cast<float>(rz[c] / pq[c]) : 0.f;
    // x += step p, r -= step q; r^T z for the new r.
    const Channels rz_next = for_gaussians([&](size_t i, Channels* sum) {
      const size_t k = per * i;
      for (int j = 0; j < per; ++j) {
        x[k + j] += step[j / kk] * p[k + j];
        r[k + j] -= step[j / kk] * q[k + j];
      }
      float z[9];
      precondition(i, &r[k], z);
      for (int j = 0; j < per; ++j) (*sum)[j / kk] += double(r[k + j]) * z[j];
    });
    float beta[3];
    for (int c = 0; c < 3; ++c) beta[c] = rz[c] > 0 ? static_cast<float>(rz_next[c] / rz[c]) : 0.f;
    for_gaussians([&](size_t i, Channels*) {
      const size_t k = per * i;
      float z[9];
      precondition(i, &r[k], z);
      for (int j = 0; j < per; ++j) p[k + j] = z[j] + beta[j / kk] * p[k + j];
    });
    rz = rz_next;
  }

  StoreColours(layout, options, &x, scene);
  for_views(
      [&](const FitView& view, ViewScratch* s) {
        Gather(view, layout, x, s);
        view_sums[&view - fit.data()] = Residual(view, s);
      },
      nullptr);
  stats->rmse_after = Rmse(total(), stats->pixels);
}

// The same fit with the weights, residual, sums and iterations on GPU
// options.device (cuda_colour_fit.h); the preconditioner is built here.
absl::Status SolveOnGpu(const std::vector<FitView>& fit, const Layout& layout,
                        const RefinementOptions& options, GaussianScene* scene,
                        std::vector<float>* x, RefinementStats* stats) {
  std::vector<ColourFitView> views;
  views.reserve(fit.size());
  for (const FitView& view : fit) {
    views.push_back({&view.a, view.fitted.data(), view.target.data()});
  }
  const auto upload_start = std::chrono::steady_clock::now();
  ASSIGN_OR_RETURN(
      std::unique_ptr<CudaColourFit> gpu,
      CudaColourFit::Upload(views, scene->size(), layout.k == 3, options.device.index));
  stats->upload_seconds = SecondsSince(upload_start);
  stats->gpu_bytes = static_cast<int64_t>(gpu->device_bytes());
  ASSIGN_OR_RETURN(const ChannelSums before, gpu->Residual(*x, /*start=*/true));
  stats->rmse_before = Rmse(before, stats->pixels);
  ASSIGN_OR_RETURN(const std::vector<float> sums, gpu->Sums());
  const Preconditioner pre = MakePreconditioner(sums, layout, options, *scene);
  RETURN_IF_ERROR(gpu->Solve(pre.PerUnknown(layout.k), pre.inverse, options.iterations, x));
  StoreColours(layout, options, x, scene);
  ASSIGN_OR_RETURN(const ChannelSums after, gpu->Residual(*x, /*start=*/false));
  stats->rmse_after = Rmse(after, stats->pixels);
  stats->on_gpu = true;
  return absl::OkStatus();
}

// RefinementOptions::max_pairs, raised by available_memory_share (the
// weights are recorded in host memory wherever the solve runs).
int64_t FitBound(const std::vector<ContextView>& views, const RefinementOptions& options,
                 size_t num_gaussians) {
  if (!(options.available_memory_share > 0)) return options.max_pairs;
  const int64_t available = AvailableMemoryBytes();
  if (available <= 0) return options.max_pairs;
  double pixels = 0;
  for (const ContextView& view : views) pixels += double(view.width()) * view.height();
  const double room = options.available_memory_share * double(available) -
                      double(kFitBytesPerGaussian) * double(num_gaussians) -
                      double(kFitBytesPerPixel) * pixels;
  return std::max(options.max_pairs, static_cast<int64_t>(room / double(kWeightUnitBytes)));
}

}  // namespace

absl::StatusOr<RefinementStats> RefineColours(const std::vector<ContextView>& views,
                                              const RefinementOptions& options,
                                              GaussianScene* scene) {
  if (scene->num_channels < 3 || scene->sh_degree >= 0) {
    return absl::InvalidArgumentError(
        "RefineColours: the scene's colour must be its first three feature channels (no SH)");
  }
  if (options.iterations < 0 || !(options.prior_weight > 0) || !(options.min_alpha >= 0) ||
      options.max_pairs <= 0 || !(options.gradient_prior_weight > 0) ||
      !(options.max_gradient >= 0) || !(options.available_memory_share >= 0) ||
      !(options.available_memory_share <= 1) || options.max_pixel_stride < 1 ||
      options.max_pixel_stride > kMaxPixelStride) {
    return absl::InvalidArgumentError(absl::StrCat(
        "RefineColours: iterations ", options.iterations, " must be >= 0, prior_weight ",
        options.prior_weight, " > 0, min_alpha ", options.min_alpha, " >= 0, max_pairs ",
        options.max_pairs, " > 0, gradient_prior_weight ", options.gradient_prior_weight,
        " > 0, max_gradient ", options.max_gradient, " >= 0, available_memory_share ",
        options.available_memory_share, " in [0, 1] and max_pixel_stride ",
        options.max_pixel_stride, " in [1, ", kMaxPixelStride, "]"));
  }
  RefinementStats stats;
  if (options.iterations == 0 || views.empty()) return stats;
  const size_t n = scene->size();
  const int stride = scene->num_channels;
  for (const ContextView& view : views) {
    if (view.rgb.channels != 3 || view.rgb.width != view.width() ||
        view.rgb.height != view.height()) {
      return absl::InvalidArgumentError(
          absl::StrCat("RefineColours: view ", view.camera_id, " at ", view.timestamp_us, " has a ",
                       view.rgb.width, "x", view.rgb.height, "x", view.rgb.channels,
                       " image for a ", view.width(), "x", view.height(), " camera"));
    }
  }

  // A_v of every view and the fitted pixels within the bound: every pixel
  // if they fit, else 1 pixel in k, k the smallest that the views recorded
  // so far say fits (a recording on every pixel measures every k), up to
  // max_pixel_stride; with gradients that do not fit even then, flat colours
  // the same way; the fit is skipped when those do not fit either.
  const int64_t num_views = static_cast<int64_t>(views.size());
  RefinementOptions bounded = options;
  bounded.max_pairs = FitBound(views, options, n);
  stats.max_pairs = bounded.max_pairs;
  bool gradients = options.colour_gradients;
  int pixel_stride = 1;
  RecordedViews recorded;
  using Clock = std::chrono::steady_clock;
  const Clock::time_point record_start = Clock::now();
  auto seconds_since = [](Clock::time_point start) {
    return std::chrono::duration<double>(Clock::now() - start).count();
  };
  for (;;) {
    ASSIGN_OR_RETURN(recorded, RecordViews(views, *scene, bounded, gradients, pixel_stride));
    stats.record_seconds = seconds_since(record_start);
    if (!recorded.over_budget) break;
    // Exact when every view was counted; else 10 % to spare.
    const double room =
        (recorded.counted_views == num_views ? 1.0 : 0.9) * double(bounded.max_pairs);
    int64_t next = 0;
    if (!recorded.entries_at.empty()) {
      // Stride 1 did not fit as recorded; flat colours on every pixel may,
      // where gradients were recorded.
      next = StrideThatFits(recorded, num_views, room, gradients, 2);
      if (next == 0 && gradients) {
        gradients = false;
        next = StrideThatFits(recorded, num_views, room, false, 1);
      }
    } else {
      // The whole clip's units at stride 1, estimated from the views counted.
      const double scale = double(num_views) / double(std::max<int64_t>(1, recorded.counted_views));
      const double entries = double(recorded.units - recorded.frame_units) * pixel_stride * scale;
      const double frames = double(recorded.frame_units) * scale;
      auto stride_for = [&](double fixed) {
        return room > fixed ? static_cast<int64_t>(std::ceil(entries / (room - fixed)))
                            : std::numeric_limits<int64_t>::max();
      };
      next = std::max<int64_t>(stride_for(gradients ? frames : 0), pixel_stride + 1);
      if (next > options.max_pixel_stride && gradients) {
        gradients = false;
        next = std::max<int64_t>(1, stride_for(0));
      }
    }
    if (next == 0 || next > options.max_pixel_stride) {
      stats.pairs = recorded.units - recorded.frame_units;
      stats.skipped_over_budget = true;
      stats.flat_fallback = options.colour_gradients;
      scene->colour_gradients.clear();
      return stats;
    }
    pixel_stride = static_cast<int>(next);
  }
  std::vector<FitView>& fit = recorded.fit;
  stats.flat_fallback = options.colour_gradients && !gradients;
  stats.pixel_stride = pixel_stride;
  stats.weight_bytes = kWeightUnitBytes * recorded.units;
  for (const FitView& view : fit) {
    stats.pairs += static_cast<int64_t>(view.a.entries());
    for (uint8_t f : view.fitted) stats.pixels += f;
  }
  if (stats.pixels == 0) return stats;

  const Clock::time_point solve_start = Clock::now();
  // x: the colours, starting at the fused ones (c0, the prior's centre, so
  // the prior enters only through Lambda). With colour gradients the
  // unknowns are [N, 3, 3] (colour, g_u, g_v per channel), the gradients
  // starting (and centred) at 0.
  const Layout layout{gradients ? 3 : 1};
  const int per = layout.per_gaussian();
  std::vector<float> x(per * n, 0.f);
  for (size_t i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c) x[per * i + layout.k * c] = scene->features[i * stride + c];
  if (options.device.kind == ComputeDevice::Kind::kCuda) {
    RETURN_IF_ERROR(SolveOnGpu(fit, layout, options, scene, &x, &stats));
  } else {
    SolveOnCpu(fit, layout, options, scene, &x, &stats);
  }
  stats.solve_seconds = seconds_since(solve_start);
  return stats;
}

}  // namespace pf
