// Depth above the LiDAR's top beam: facades continued up to the roof where
// other views agree.
#include "engine/recon/facade_depth.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>

#include "common/thread_pool.h"
#include "engine/camera/camera_model.h"
#include "engine/camera/image_pixel.h"

namespace pf {
namespace {

// A point this far along a ray stands for the far layer (metres).
constexpr double kFarDistance = 1e4;
// Metres: the top points' standard deviation along the facade must exceed
// this for the facade's direction to be known.
constexpr double kMinFacadeSpread = 0.03;

// Whether the 3x3 patch around (x, y) lies in `view`'s image and off its
// ego body.
bool PatchUsable(const ContextView& view, int x, int y) {
  if (x < 1 || y < 1 || x >= view.width() - 1 || y >= view.height() - 1) return false;
  if (view.ego.empty()) return true;
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx)
      if (view.is_ego(static_cast<size_t>(y + dy) * view.width() + (x + dx))) return false;
  return true;
}

// Mean absolute difference between the 3x3 RGB patches of `a` around
// (ax, ay) and of `b` around (bx, by); -1 when a patch leaves its image or
// touches its view's ego body (the body says nothing of the scene).
double PatchCost(const ContextView& a, int ax, int ay, const ContextView& b, int bx, int by) {
  if (!PatchUsable(a, ax, ay) || !PatchUsable(b, bx, by)) return -1;
  double sum = 0;
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx)
      for (int c = 0; c < 3; ++c)
        sum += std::abs(a.rgb.at(ax + dx, ay + dy, c) - b.rgb.at(bx + dx, by + dy, c));
  return sum / 27;
}

// The pixel of `view` (its line poses `lines`) that sees world point `p`;
// false when none does.
bool PixelOf(const ContextView& view, const LinePoses& lines, const Vec3& p, int* x, int* y) {
  double u, v;
  if (!lines.Project(p, &u, &v)) return false;
  return PixelInImage(u, v, view.width(), view.height(), x, y);
}

// The views that check one view's pixels (the `count` nearest at least
// `min_baseline` away), and how they see a pixel's patch.
class Checkers {
 public:
  Checkers(const std::vector<ContextView>& views, size_t v, double min_baseline, int count)
      : views_(views),
        view_(views[v]),
        partners_(CheckingViews(views, v, min_baseline, std::numeric_limits<double>::infinity(),
                                0.0, count)) {
    for (size_t u : partners_) lines_.push_back(views[u].lines());
  }
  bool empty() const { return partners_.empty(); }

  enum class Verdict {
    kUndecided,  // No checking view sees both points, or the far point's patch is flat.
    kNear,       // `near` matches clearly better (cost < accept_ratio x the far point's).
    kFar,        // The far point matches better.
    kNeither,
  };
  // Compares the 3x3 patch of pixel (x, y) with what the checking views see
  // at world points `near` and `far` (PatchCost, summed over the views that
  // see both).
  Verdict Ask(int x, int y, const Vec3& near, const Vec3& far, double accept_ratio,
              double min_contrast) const {
    double cost_near = 0, cost_far = 0;
    int seen = 0;
    for (size_t k = 0; k < partners_.size(); ++k) {
      const ContextView& other = views_[partners_[k]];
      int px, py, fx, fy;
      if (!PixelOf(other, lines_[k], near, &px, &py) || !PixelOf(other, lines_[k], far, &fx, &fy)) {
        continue;
      }
      const double cn = PatchCost(view_, x, y, other, px, py);
      const double cf = PatchCost(view_, x, y, other, fx, fy);
      if (cn < 0 || cf < 0) continue;
      cost_near += cn;
      cost_far += cf;
      ++seen;
    }
    if (seen == 0 || cost_far / seen < min_contrast) return Verdict::kUndecided;
    if (cost_near < accept_ratio * cost_far) return Verdict::kNear;
    return cost_near > cost_far ? Verdict::kFar : Verdict::kNeither;
  }

 private:
  const std::vector<ContextView>& views_;
  const ContextView& view_;
  std::vector<size_t> partners_;
  std::vector<LinePoses> lines_;
};

// A vertical plane: the points p with Dot(normal, p) = offset.
struct Facade {
  Vec3 normal;  // Horizontal.
  double offset = 0;
  double top_height = 0;  // Height above the ground of the highest top point.
};

}  // namespace

int64_t ExtendFacades(const std::vector<ContextView>& views, const std::vector<bool>& extend,
                      const std::vector<GroundPlane>& grounds, std::vector<ImageF>* measured,
                      const FacadeOptions& options) {
  int64_t total = 0;
  for (size_t v = 0; v < views.size(); ++v) {
    if (!extend[v] || !grounds[v].valid) continue;
    const Checkers checkers(views, v, options.min_baseline, options.partners);
    if (checkers.empty()) continue;
    const ContextView& view = views[v];
    const GroundPlane& ground = grounds[v];
    const ImageF before = (*measured)[v];
    ImageF& depth = (*measured)[v];
    const int w = before.width, h = before.height;
    const Vec3 up = ground.normal;
    Vec3 e1, e2;
    LevelAxes(up, &e1, &e2);
    const LinePoses lines = view.lines();

    // The highest known pixel of every column, and the world point of a pixel.
    std::vector<int> top(w, -1);
    for (int x = 0; x < w; ++x) {
      for (int y = 0; y < h; ++y) {
        if (before.at(x, y) > 0.f) {
          top[x] = y;
          break;
        }
      }
    }
    // The ray through pixel (x, y) from its line's centre `origin`.
    auto ray_of = [&](int x, int y, Vec3* origin, Vec3* dir) {
      Vec3 ray;
      if (!view.camera.Unproject(x + 0.5, y + 0.5, &ray)) return false;
      const Rigid pose = lines.WorldFromCameraAt(x + 0.5, y + 0.5);
      *origin = pose.translation;
      *dir = pose.rotation * ray;  // z-scaled: z depth s gives o + s dir.
      return true;
    };

    std::atomic<int64_t> set{0};
    DefaultThreadPool().ParallelFor(0, w, 8, [&](int64_t x0, int64_t x1) {
      std::vector<float> column(h);
      for (int64_t xl = x0; xl < x1; ++xl) {
        const int x = static_cast<int>(xl);
        if (top[x] <= 0) continue;
        // The top points of the columns around: their horizontal coordinates.
        double sa = 0, sb = 0, saa = 0, sab = 0, sbb = 0, top_height = -1e30;
        int count = 0;
        for (int cx = std::max(0, x - options.window_px);
             cx <= std::min(w - 1, x + options.window_px); ++cx) {
          if (top[cx] < 0) continue;
          for (int y = top[cx]; y < std::min(h, top[cx] + options.band_px); ++y) {
            Vec3 p;
            if (!lines.Lift(cx + 0.5, y + 0.5, before.at(cx, y), &p)) continue;
            const double height = Dot(up, p) - ground.offset;
            if (height < options.min_height) continue;
            const double a = Dot(p, e1), b = Dot(p, e2);
            sa += a;
            sb += b;
            saa += a * a;
            sab += a * b;
            sbb += b * b;
            top_height = std::max(top_height, height);
            ++count;
          }
        }
        if (count < 8) continue;
        const double ma = sa / count, mb = sb / count;
        const double caa = saa / count - ma * ma, cab = sab / count - ma * mb,
                     cbb = sbb / count - mb * mb;
        const double half = 0.5 * (caa + cbb);
        const double root = std::sqrt(std::max(0.0, 0.25 * (caa - cbb) * (caa - cbb) + cab * cab));
        const double minor = std::max(0.0, half - root), major = half + root;
        // A line seen from above: thin across, and long enough along to
        // give its direction.
        if (std::sqrt(minor) > options.max_plane_rms || major < 4 * minor ||
            major < kMinFacadeSpread * kMinFacadeSpread) {
          continue;
        }
        // Along the facade: the major axis; the normal is perpendicular.
        double ta = cab, tb = major - caa;
        if (std::abs(ta) + std::abs(tb) < 1e-12) {
          ta = caa >= cbb ? 1 : 0;
          tb = caa >= cbb ? 0 : 1;
        }
        const double tn = std::hypot(ta, tb);
        Facade facade;
        const double na = -tb / tn, nb = ta / tn;
        facade.normal = na * e1 + nb * e2;
        facade.offset = na * ma + nb * mb;
        facade.top_height = top_height;

        // Scan up the column.
        int last_accept = -1, rejections = 0;
        for (int y = top[x] - 1; y >= 0; --y) {
          column[y] = 0.f;
          Vec3 origin, dir;
          if (!ray_of(x, y, &origin, &dir)) break;
          const double denom = Dot(facade.normal, dir);
          if (std::abs(denom) < 1e-9) break;
          const double s = (facade.offset - Dot(facade.normal, origin)) / denom;
          if (!(s > 0)) break;
          const Vec3 p = origin + s * dir;
          if (Dot(up, p) - ground.offset > facade.top_height + options.max_rise) break;
          const Vec3 far = origin + (kFarDistance / Norm(dir)) * dir;
          column[y] = static_cast<float>(s);
          const Checkers::Verdict verdict =
              checkers.Ask(x, y, p, far, options.accept_ratio, options.min_contrast);
          if (verdict == Checkers::Verdict::kNear) {
            last_accept = y;
            rejections = 0;
          } else if (verdict == Checkers::Verdict::kFar) {
            if (++rejections >= options.stop_after) break;
          }
        }
        if (last_accept < 0) continue;
        int64_t local = 0;
        for (int y = last_accept; y < top[x]; ++y) {
          if (column[y] > 0.f) {
            depth.at(x, y) = column[y];
            ++local;
          }
        }
        set += local;
      }
    });
    total += set.load();
  }
  return total;
}

int64_t ExtendUpward(const std::vector<ContextView>& views, const std::vector<bool>& extend,
                     std::vector<ImageF>* measured, const UpwardOptions& options) {
  int64_t total = 0;
  for (size_t v = 0; v < views.size(); ++v) {
    if (!extend[v]) continue;
    const Checkers checkers(views, v, options.min_baseline, options.partners);
    if (checkers.empty()) continue;
    // Read from `before`, so that no column sees another's new depths.
    const ImageF before = (*measured)[v];
    ImageF& depth = (*measured)[v];
    const int w = before.width, h = before.height;
    const LinePoses lines = views[v].lines();
    // The median known depth in the band_px rows under row `y` of the
    // columns around x; 0 with fewer than 8.
    auto depth_below = [&](int x, int y, std::vector<float>* band) {
      band->clear();
      for (int cx = std::max(0, x - options.window_px);
           cx <= std::min(w - 1, x + options.window_px); ++cx) {
        for (int yy = y + 1; yy < std::min(h, y + 1 + options.band_px); ++yy) {
          if (before.at(cx, yy) > 0.f) band->push_back(before.at(cx, yy));
        }
      }
      if (band->size() < 8) return 0.f;
      std::nth_element(band->begin(), band->begin() + long(band->size() / 2), band->end());
      return (*band)[band->size() / 2];
    };
    std::atomic<int64_t> set{0};
    DefaultThreadPool().ParallelFor(0, w, 8, [&](int64_t x0, int64_t x1) {
      std::vector<float> band;
      for (int64_t xl = x0; xl < x1; ++xl) {
        const int x = static_cast<int>(xl);
        int64_t local = 0;
        bool below_known = false;  // The pixel under this one is known.
        float prior = 0.f;         // The open run's depth; 0: no run open.
        int rejections = 0;
        for (int y = h - 1; y >= 0; --y) {
          if (before.at(x, y) > 0.f) {
            below_known = true;
            continue;
          }
          if (below_known) {  // A run starts.
            below_known = false;
            prior = depth_below(x, y, &band);
            rejections = 0;
          }
          if (prior == 0.f) continue;
          Vec3 p, far;
          if (!lines.Lift(x + 0.5, y + 0.5, prior, &p) ||
              !lines.Lift(x + 0.5, y + 0.5, float(kFarDistance), &far)) {
            prior = 0.f;
            continue;
          }
          const Checkers::Verdict verdict =
              checkers.Ask(x, y, p, far, options.accept_ratio, options.min_contrast);
          if (verdict == Checkers::Verdict::kNear) {
            depth.at(x, y) = prior;
            ++local;
            rejections = 0;
          } else if (verdict == Checkers::Verdict::kFar && ++rejections >= options.stop_after) {
            prior = 0.f;
          }
        }
        set += local;
      }
    });
    total += set.load();
  }
  return total;
}

}  // namespace pf
