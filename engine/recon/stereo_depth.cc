// Depth from the context views where no sensor measured it: a plane sweep
// with NCC over reduced grey images.
#include "engine/recon/stereo_depth.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>

#include "common/thread_pool.h"
#include "engine/camera/camera_model.h"

namespace pf {
namespace {

constexpr float kNoScore = -2.f;  // A score no NCC takes.
constexpr int kBlockRows = 16;    // Output rows per task.

// A view's image reduced by a whole factor: grey (Rec. 601 luma of the
// working colours), and 1 where any pixel of the cell is on the ego body.
struct ReducedGrey {
  int factor = 1;
  int width = 0;
  int height = 0;
  std::vector<float> grey;
  std::vector<uint8_t> ego;
};

ReducedGrey ReduceToGrey(const ContextView& view, int max_width) {
  ReducedGrey r;
  r.factor = std::max(1, (view.width() + max_width - 1) / max_width);
  r.width = view.width() / r.factor;
  r.height = view.height() / r.factor;
  r.grey.assign(static_cast<size_t>(r.width) * r.height, 0.f);
  r.ego.assign(r.grey.size(), 0);
  const int f = r.factor;
  const float norm = 1.f / static_cast<float>(f * f);
  for (int y = 0; y < r.height; ++y) {
    for (int x = 0; x < r.width; ++x) {
      float sum = 0;
      uint8_t ego = 0;
      for (int dy = 0; dy < f; ++dy) {
        for (int dx = 0; dx < f; ++dx) {
          const int fx = x * f + dx, fy = y * f + dy;
          sum += 0.299f * view.rgb.at(fx, fy, 0) + 0.587f * view.rgb.at(fx, fy, 1) +
                 0.114f * view.rgb.at(fx, fy, 2);
          ego |= view.is_ego(static_cast<size_t>(fy) * view.width() + fx) ? 1 : 0;
        }
      }
      r.grey[static_cast<size_t>(y) * r.width + x] = sum * norm;
      r.ego[static_cast<size_t>(y) * r.width + x] = ego;
    }
  }
  return r;
}

// A partner as the sweep sees it: the reduced image, and each reference
// ray in the partner's camera frame, a + d b at reference z depth d.
struct PartnerRays {
  const ReducedGrey* image = nullptr;
  const CameraModel* camera = nullptr;
  std::vector<Vec3> a;
  std::vector<Vec3> b;
};

// Bilinear grey of `r` at full-resolution continuous pixel (u, v); NaN
// outside the image or next to the ego body.
float SampleGrey(const ReducedGrey& r, double u, double v) {
  const double x = u / r.factor - 0.5, y = v / r.factor - 0.5;
  if (!(x >= 0 && y >= 0 && x <= r.width - 1 && y <= r.height - 1))
    return std::numeric_limits<float>::quiet_NaN();
  const int x0 = std::min(static_cast<int>(x), r.width - 2 < 0 ? 0 : r.width - 2);
  const int y0 = std::min(static_cast<int>(y), r.height - 2 < 0 ? 0 : r.height - 2);
  const int x1 = std::min(x0 + 1, r.width - 1), y1 = std::min(y0 + 1, r.height - 1);
  const size_t i00 = static_cast<size_t>(y0) * r.width + x0,
               i01 = static_cast<size_t>(y0) * r.width + x1,
               i10 = static_cast<size_t>(y1) * r.width + x0,
               i11 = static_cast<size_t>(y1) * r.width + x1;
  if (r.ego[i00] | r.ego[i01] | r.ego[i10] | r.ego[i11])
    return std::numeric_limits<float>::quiet_NaN();
  const float fx = static_cast<float>(x - x0), fy = static_cast<float>(y - y0);
  const float top = r.grey[i00] + fx * (r.grey[i01] - r.grey[i00]);
  const float bottom = r.grey[i10] + fx * (r.grey[i11] - r.grey[i10]);
  return top + fy * (bottom - top);
}

}  // namespace

StereoStats ExtendByStereo(const std::vector<ContextView>& views, const std::vector<bool>& extend,
                           std::vector<ImageF>* measured, const StereoOptions& options) {
  StereoStats stats;
  const size_t n = views.size();
  std::vector<ReducedGrey> reduced(n);
  std::vector<bool> needed(n, false);
  std::vector<std::vector<size_t>> partners(n);
  for (size_t v = 0; v < n; ++v) {
    if (!extend[v]) continue;
    partners[v] =
        CheckingViews(views, v, options.min_baseline, options.max_baseline, 0.5, options.partners);
    if (partners[v].empty()) continue;
    needed[v] = true;
    for (size_t u : partners[v]) needed[u] = true;
  }
  DefaultThreadPool().ParallelFor(0, static_cast<int64_t>(n), 1, [&](int64_t b, int64_t e) {
    for (int64_t v = b; v < e; ++v)
      if (needed[v]) reduced[v] = ReduceToGrey(views[v], options.max_width);
  });

  const int r = options.window_radius;
  const int window = (2 * r + 1) * (2 * r + 1);
  double ncc_sum = 0;
  for (size_t v = 0; v < n; ++v) {
    if (!extend[v] || partners[v].empty()) continue;
    const ContextView& view = views[v];
    const ReducedGrey& ref = reduced[v];
    ImageF& depth = (*measured)[v];
    const int w = ref.width, h = ref.height, f = ref.factor;
    if (w <= 2 * r || h <= 2 * r) continue;

    // Cells with an unknown, non-ego full-resolution pixel.
    std::vector<uint8_t> candidate(static_cast<size_t>(w) * h, 0);
    int64_t unknown = 0;
    for (int y = 0; y < h * f; ++y) {
      for (int x = 0; x < w * f; ++x) {
        const size_t j = static_cast<size_t>(y) * view.width() + x;
        if (depth.at(x, y) > 0.f || view.is_ego(j)) continue;
        candidate[static_cast<size_t>(y / f) * w + x / f] = 1;
        ++unknown;
      }
    }
    if (unknown == 0) continue;
    stats.candidates += unknown;

    // The reference patches: those with texture and off the ego body are
    // tried; their sums for the NCC.
    std::vector<uint8_t> active(candidate.size(), 0);
    std::vector<float> sum_r(candidate.size(), 0.f), var_r(candidate.size(), 0.f);
    int y_lo = h, y_hi = -1;
    for (int y = r; y < h - r; ++y) {
      for (int x = r; x < w - r; ++x) {
        const size_t i = static_cast<size_t>(y) * w + x;
        if (!candidate[i]) continue;
        double s = 0, ss = 0;
        bool ego = false;
        for (int dy = -r; dy <= r; ++dy) {
          for (int dx = -r; dx <= r; ++dx) {
            const size_t k = static_cast<size_t>(y + dy) * w + x + dx;
            s += ref.grey[k];
            ss += static_cast<double>(ref.grey[k]) * ref.grey[k];
            ego |= ref.ego[k] != 0;
          }
        }
        const double var = ss - s * s / window;
        if (ego || var < options.min_texture * options.min_texture * window) continue;
        active[i] = 1;
        sum_r[i] = static_cast<float>(s);
        var_r[i] = static_cast<float>(var);
        y_lo = std::min(y_lo, y);
        y_hi = std::max(y_hi, y);
      }
    }
    if (y_hi < 0) continue;
    ++stats.views;

    // The rays of the rows the active patches reach, in each partner's frame.
    const int row0 = y_lo - r, row1 = y_hi + r + 1;  // [row0, row1)
    const LinePoses lines = view.lines();
    const size_t k_count = partners[v].size();
    std::vector<PartnerRays> rays(k_count);
    double widest = 0;
    for (size_t k = 0; k < k_count; ++k) {
      const ContextView& other = views[partners[v][k]];
      rays[k].image = &reduced[partners[v][k]];
      rays[k].camera = &other.camera;
      rays[k].a.assign(static_cast<size_t>(row1 - row0) * w, Vec3{0, 0, 0});
      rays[k].b.assign(rays[k].a.size(), Vec3{0, 0, 0});
      widest = std::max(
          widest, Norm(other.world_from_camera.translation - view.world_from_camera.translation));
    }
    std::vector<Rigid> partner_from_world(k_count);
    for (size_t k = 0; k < k_count; ++k)
      partner_from_world[k] = views[partners[v][k]].lines().MiddleWorldFromCamera().Inverse();
    std::vector<uint8_t> ray_ok(static_cast<size_t>(row1 - row0) * w, 0);
    for (int y = row0; y < row1; ++y) {
      for (int x = 0; x < w; ++x) {
        const double u = (x + 0.5) * f, vv = (y + 0.5) * f;
        Vec3 ray;
        if (!view.camera.Unproject(u, vv, &ray)) continue;
        const Rigid pose = lines.WorldFromCameraAt(u, vv);
        const Vec3 dir = pose.rotation * ray;
        const size_t i = static_cast<size_t>(y - row0) * w + x;
        ray_ok[i] = 1;
        for (size_t k = 0; k < k_count; ++k) {
          rays[k].a[i] = partner_from_world[k] * pose.translation;
          rays[k].b[i] = partner_from_world[k].rotation * dir;
        }
      }
    }

    // Depths evenly spaced in inverse depth, one step of parallax apart in
    // the widest pair; plane 0 is the farthest.
    const double q_near = 1 / options.min_depth, q_far = 1 / options.max_depth;
    const double focal = std::max(view.camera.fx(), view.camera.fy()) / f;
    const int planes = std::clamp(
        static_cast<int>(std::ceil((q_near - q_far) * focal * widest / options.step_px)) + 1, 8,
        options.max_planes);
    const double dq = (q_near - q_far) / (planes - 1);

    std::vector<float> cell_depth(candidate.size(), 0.f), cell_ncc(candidate.size(), 0.f);
    const int blocks = (y_hi - y_lo + kBlockRows) / kBlockRows;
    DefaultThreadPool().ParallelFor(0, blocks, 1, [&](int64_t b0, int64_t b1) {
      for (int64_t block = b0; block < b1; ++block) {
        const int out0 = y_lo + static_cast<int>(block) * kBlockRows;
        const int out1 = std::min(y_hi + 1, out0 + kBlockRows);
        const int in0 = out0 - r, in1 = out1 + r;
        const int in_rows = in1 - in0, out_rows = out1 - out0;
        // Which input pixels some active patch of the block needs.
        std::vector<uint8_t> wanted(static_cast<size_t>(in_rows) * w, 0);
        bool any = false;
        for (int y = out0; y < out1; ++y) {
          for (int x = r; x < w - r; ++x) {
            if (!active[static_cast<size_t>(y) * w + x]) continue;
            any = true;
            for (int dy = -r; dy <= r; ++dy)
              std::fill_n(wanted.begin() + static_cast<size_t>(y + dy - in0) * w + x - r, 2 * r + 1,
                          uint8_t{1});
          }
        }
        if (!any) continue;
        // score[p][plane]: mean NCC over the partners that see the point;
        // worst[p][plane]: the lowest of theirs.
        const size_t cells = static_cast<size_t>(out_rows) * w;
        std::vector<float> score(cells * planes, kNoScore), worst(cells * planes, kNoScore);
        std::vector<float> warped(static_cast<size_t>(in_rows) * w);
        std::vector<float> col_w(static_cast<size_t>(out_rows) * w), col_ww(col_w.size()),
            col_rw(col_w.size());
        std::vector<uint8_t> col_bad(col_w.size());
        std::vector<float> ncc(cells * k_count);
        for (int plane = 0; plane < planes; ++plane) {
          const double d = 1 / (q_far + plane * dq);
          for (size_t k = 0; k < k_count; ++k) {
            const PartnerRays& pr = rays[k];
            for (int y = in0; y < in1; ++y) {
              for (int x = 0; x < w; ++x) {
                const size_t wi = static_cast<size_t>(y - in0) * w + x;
                float value = std::numeric_limits<float>::quiet_NaN();
                const size_t ri = static_cast<size_t>(y - row0) * w + x;
                if (wanted[wi] && ray_ok[ri]) {
                  double u, vv;
                  if (pr.camera->Project(pr.a[ri] + d * pr.b[ri], &u, &vv))
                    value = SampleGrey(*pr.image, u, vv);
                }
                warped[wi] = value;
              }
            }
            // Column sums over the window's rows, then each active patch's.
            for (int y = out0; y < out1; ++y) {
              for (int x = 0; x < w; ++x) {
                const size_t oi = static_cast<size_t>(y - out0) * w + x;
                float sw = 0, sww = 0, srw = 0;
                bool bad = false;
                for (int dy = -r; dy <= r; ++dy) {
                  const float value = warped[static_cast<size_t>(y + dy - in0) * w + x];
                  if (std::isnan(value)) {
                    bad = true;
                    break;
                  }
                  sw += value;
                  sww += value * value;
                  srw += value * ref.grey[static_cast<size_t>(y + dy) * w + x];
                }
                col_w[oi] = sw;
                col_ww[oi] = sww;
                col_rw[oi] = srw;
                col_bad[oi] = bad;
              }
            }
            for (int y = out0; y < out1; ++y) {
              for (int x = r; x < w - r; ++x) {
                const size_t i = static_cast<size_t>(y) * w + x;
                const size_t oi = static_cast<size_t>(y - out0) * w + x;
                float& out = ncc[oi * k_count + k];
                out = kNoScore;
                if (!active[i]) continue;
                float sw = 0, sww = 0, srw = 0;
                bool bad = false;
                for (int dx = -r; dx <= r; ++dx) {
                  bad |= col_bad[oi + dx] != 0;
                  sw += col_w[oi + dx];
                  sww += col_ww[oi + dx];
                  srw += col_rw[oi + dx];
                }
                if (bad) continue;
                const float var_w = sww - sw * sw / window;
                if (var_w <= 1e-9f) continue;
                out = (srw - sum_r[i] * sw / window) / std::sqrt(var_r[i] * var_w);
              }
            }
          }
          for (size_t c = 0; c < cells; ++c) {
            float sum = 0, low = 1;
            int seen = 0;
            for (size_t k = 0; k < k_count; ++k) {
              const float value = ncc[c * k_count + k];
              if (value == kNoScore) continue;
              sum += value;
              low = std::min(low, value);
              ++seen;
            }
            if (seen == 0) continue;
            score[c * planes + plane] = sum / static_cast<float>(seen);
            worst[c * planes + plane] = low;
          }
        }
        // Each active patch's best depth, if the evidence is clear.
        for (int y = out0; y < out1; ++y) {
          for (int x = r; x < w - r; ++x) {
            const size_t i = static_cast<size_t>(y) * w + x;
            if (!active[i]) continue;
            const float* s = &score[(static_cast<size_t>(y - out0) * w + x) * planes];
            const float* lowest = &worst[(static_cast<size_t>(y - out0) * w + x) * planes];
            int best = -1;
            for (int p = 0; p < planes; ++p)
              if (s[p] != kNoScore && (best < 0 || s[p] > s[best])) best = p;
            if (best < std::max(1, options.far_planes) || best >= planes - 1) continue;
            if (s[best] < options.min_ncc || lowest[best] < options.min_partner_ncc) continue;
            float rival = -1;
            for (int p = 0; p < planes; ++p)
              if (std::abs(p - best) >= options.unique_planes && s[p] != kNoScore)
                rival = std::max(rival, s[p]);
            if (1 - s[best] > options.uniqueness * (1 - rival)) continue;
            // Sub-plane: the parabola through the best and its neighbours.
            double offset = 0;
            if (s[best - 1] != kNoScore && s[best + 1] != kNoScore) {
              const double curve = s[best - 1] - 2.0 * s[best] + s[best + 1];
              if (curve < 0)
                offset = std::clamp(0.5 * (s[best - 1] - s[best + 1]) / curve, -0.5, 0.5);
            }
            cell_depth[i] = static_cast<float>(1 / (q_far + (best + offset) * dq));
            cell_ncc[i] = s[best];
          }
        }
      }
    });

    // Every unknown pixel of an accepted cell takes its depth.
    int64_t set = 0;
    for (int y = 0; y < h * f; ++y) {
      for (int x = 0; x < w * f; ++x) {
        const size_t j = static_cast<size_t>(y) * view.width() + x;
        const size_t i = static_cast<size_t>(y / f) * w + x / f;
        if (cell_depth[i] <= 0.f || depth.at(x, y) > 0.f || view.is_ego(j)) continue;
        depth.at(x, y) = cell_depth[i];
        ncc_sum += cell_ncc[i];
        ++set;
      }
    }
    stats.pixels += set;
  }
  if (stats.pixels > 0) stats.mean_ncc = ncc_sum / static_cast<double>(stats.pixels);
  return stats;
}

}  // namespace pf
