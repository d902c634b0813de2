// Stratified, coverage-aware choice of static and dynamic queries.
#include "engine/recon/sparse_sampling.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <tuple>
#include <vector>

#include "absl/container/flat_hash_map.h"
#include "absl/container/flat_hash_set.h"
#include "common/thread_pool.h"
#include "engine/camera/image_pixel.h"
#include "engine/recon/scene_graph.h"
#include "spdlog/spdlog.h"

namespace pf {
namespace {

// A candidate query before it is written to the set.
struct Candidate {
  int view;
  int pixel;
  Vec3 position;  // World or canonical.
  float footprint;
  // A hidden query (behind the surface `pixel` sees): the pixel whose
  // normal and layer it takes, and its z depth in the view; -1 for ordinary
  // ones. Its colour is set later (HiddenColour).
  int source_pixel = -1;
  float depth = -1.f;
};

// The colour of hidden query `query`: SeenSurfaces::Colour of its position,
// else BackgroundColour(view, pixel, source, reach); found once the static
// queries are final (the first pass is sampled again when the budget is
// refined) and for all of them at once.
struct HiddenColour {
  size_t query;
  int view;
  size_t pixel, source;
  int reach;
};

// Returns a hash of three integers mapped to [0, 1).
double Hash01(uint64_t a, uint64_t b, uint64_t c) {
  uint64_t h = a * 0x9E3779B97F4A7C15ull ^ (b + 0x632BE59BD9B4E5ull) * 0xBF58476D1CE4E5B9ull ^
               (c + 1) * 0x94D049BB133111EBull;
  h ^= h >> 31;
  h *= 0xD6E8FEB86659FD93ull;
  h ^= h >> 32;
  return double(h >> 11) * (1.0 / 9007199254740992.0);
}

// Returns the pixel of grid cell `cell` along an axis of `size` pixels, the
// cells `stride` >= 1 pixels wide: one of the pixels whose centre lies in
// the cell, picked by `u` in [0, 1). Cells hold disjoint pixels, so no two
// cells of a grid pick the same one.
int CellPixel(int cell, double stride, double u, int size) {
  const int first = static_cast<int>(std::ceil(cell * stride - 0.5));
  const int end = static_cast<int>(std::ceil((cell + 1) * stride - 0.5));
  const int count = std::max(1, end - first);
  return std::min(size - 1, first + std::min(count - 1, static_cast<int>(u * count)));
}

// Returns a key of the voxel of side `side` that holds `p`, tagged with
// `level` so grids of different sides do not collide.
uint64_t VoxelKey(const Vec3& p, double side, uint32_t level) {
  auto q = [&](double v) {
    const int64_t i = static_cast<int64_t>(std::floor(v / side)) + (int64_t(1) << 18);
    return static_cast<uint64_t>(std::clamp<int64_t>(i, 0, (int64_t(1) << 19) - 1));
  };
  return (uint64_t(level & 63) << 57) | (q(p.x) << 38) | (q(p.y) << 19) | q(p.z);
}

// Returns the power-of-two level of a footprint (1 cm at level 20): the
// smallest voxel side >= the footprint, so a voxel of a covered surface
// nearly always holds a sample.
uint32_t FootprintLevel(double footprint) {
  const int level = static_cast<int>(std::ceil(std::log2(std::max(footprint, 1e-6) / 0.01))) + 20;
  return static_cast<uint32_t>(std::clamp(level, 0, 63));
}

double LevelSide(uint32_t level) { return 0.01 * std::pow(2.0, int(level) - 20); }

double FocalLength(const CameraModel& camera) { return 0.5 * (camera.fx() + camera.fy()); }

// A pixel's footprint per metre of depth (z): the range per metre of z times
// the widest angle the pixel spans (the largest singular value of the
// Jacobian of the unit ray by the pixel). For a pinhole camera that is
// 1 / focal length exactly, and footprints are depth / focal as ever; for a
// distorted lens (a wide f-theta or fisheye one, whose pixels span far
// wider angles at the edge than at the centre) it is taken on a grid of
// nodes kGridPx apart (covering the image) and interpolated bilinearly. A
// node the lens does not reach takes the widest of its neighbours'.
class PixelFootprints {
 public:
  explicit PixelFootprints(const CameraModel& camera)
      : focal_(FocalLength(camera)), width_(camera.width()) {
    if (!camera.has_distortion()) return;
    nx_ = (camera.width() + kGridPx - 1) / kGridPx + 1;
    ny_ = (camera.height() + kGridPx - 1) / kGridPx + 1;
    grid_.resize(static_cast<size_t>(nx_) * ny_);
    bool any = false;
    for (int gy = 0; gy < ny_; ++gy) {
      for (int gx = 0; gx < nx_; ++gx) {
        const double value = PerDepth(camera, gx * kGridPx, gy * kGridPx);
        grid_[static_cast<size_t>(gy) * nx_ + gx] = value;
        any = any || value > 0;
      }
    }
    if (!any) {
      std::fill(grid_.begin(), grid_.end(), 1 / focal_);
      return;
    }
    // Unreached nodes (0) take the widest reached neighbour's, ring by ring.
    for (bool changed = true; changed;) {
      changed = false;
      std::vector<double> next = grid_;
      for (int gy = 0; gy < ny_; ++gy) {
        for (int gx = 0; gx < nx_; ++gx) {
          double& node = next[static_cast<size_t>(gy) * nx_ + gx];
          if (node > 0) continue;
          constexpr int kSteps[4][2] = {{-1, 0}, {1, 0}, {0, -1}, {0, 1}};
          for (const auto& step : kSteps) {
            const int x = gx + step[0], y = gy + step[1];
            if (x < 0 || y < 0 || x >= nx_ || y >= ny_) continue;
            node = std::max(node, grid_[static_cast<size_t>(y) * nx_ + x]);
          }
          changed = changed || node > 0;
        }
      }
      grid_.swap(next);
    }
  }

  bool pinhole() const { return grid_.empty(); }

  // The footprint of a surface at z depth `depth` seen in pixel `i`.
  double Of(double depth, size_t i) const {
    if (grid_.empty()) return depth / focal_;
    const double x = (static_cast<double>(i % width_) + 0.5) / kGridPx;
    const double y = (static_cast<double>(i / width_) + 0.5) / kGridPx;
    const int x0 = std::min(static_cast<int>(x), nx_ - 2);
    const int y0 = std::min(static_cast<int>(y), ny_ - 2);
    const double fx = x - x0, fy = y - y0;
    const double* row0 = &grid_[static_cast<size_t>(y0) * nx_ + x0];
    const double* row1 = row0 + nx_;
    const double top = row0[0] + fx * (row0[1] - row0[0]);
    const double bottom = row1[0] + fx * (row1[1] - row1[0]);
    return depth * (top + fy * (bottom - top));
  }

 private:
  static constexpr int kGridPx = 16;

  // The footprint per metre of depth at pixel position (u, v); 0 where the
  // lens does not reach.
  static double PerDepth(const CameraModel& camera, double u, double v) {
    Vec3 centre, du_plus, du_minus, dv_plus, dv_minus;
    if (!camera.Unproject(u, v, &centre) || !camera.Unproject(u + 0.5, v, &du_plus) ||
        !camera.Unproject(u - 0.5, v, &du_minus) || !camera.Unproject(u, v + 0.5, &dv_plus) ||
        !camera.Unproject(u, v - 0.5, &dv_minus)) {
      return 0;
    }
    const Vec3 a = Normalized(du_plus) - Normalized(du_minus);
    const Vec3 b = Normalized(dv_plus) - Normalized(dv_minus);
    // Largest eigenvalue of [a.a a.b; a.b b.b].
    const double aa = Dot(a, a), ab = Dot(a, b), bb = Dot(b, b);
    const double half_trace = 0.5 * (aa + bb);
    const double widest = std::sqrt(
        half_trace + std::sqrt(std::max(0.0, half_trace * half_trace - (aa * bb - ab * ab))));
    return Norm(centre) * widest;  // centre has z = 1: its length is range per z.
  }

  double focal_;
  int width_;
  int nx_ = 0, ny_ = 0;
  std::vector<double> grid_;  // Footprint per metre of depth at the grid's nodes.
};

// Returns true if pixel `i` of `depth` is on the near side of an occluding
// edge: a pixel of its 3x3 neighbourhood holds a surface more than `min_jump`
// (relative) deeper. The far layer does not count.
bool AtNearSideOfEdge(const ViewDepth& depth, size_t i, double min_jump) {
  if (depth.is_far(i)) return false;
  const int x = static_cast<int>(i % depth.width), y = static_cast<int>(i / depth.width);
  const double deeper = (1 + min_jump) * depth.depth[i];
  for (int dy = -1; dy <= 1; ++dy) {
    for (int dx = -1; dx <= 1; ++dx) {
      const int qx = x + dx, qy = y + dy;
      if (qx < 0 || qy < 0 || qx >= depth.width || qy >= depth.height) continue;
      const size_t j = static_cast<size_t>(qy) * depth.width + qx;
      if (!depth.is_far(j) && depth.depth[j] > deeper) return true;
    }
  }
  return false;
}

// Writes `c` to `out` with the frame change `to_frame` (identity for static).
// A visible query on the near side of an occluding edge gets its footprint
// scaled by options.edge_footprint_scale.
void Emit(const Candidate& c, const SamplingView& sv, uint32_t owner, const Rigid& to_frame,
          const SamplingOptions& options, QuerySet* out) {
  const ContextView& view = *sv.view;
  const size_t i = static_cast<size_t>(c.pixel);
  const bool hidden = c.source_pixel >= 0;
  // Colour, normal and layer come from the pixel the query shows (a hidden
  // query's colour is replaced in SampleQueries).
  const size_t shown = hidden ? static_cast<size_t>(c.source_pixel) : i;
  const int x = static_cast<int>(shown % view.width()), y = static_cast<int>(shown / view.width());
  const Vec3 world{sv.lifted->points[3 * i], sv.lifted->points[3 * i + 1],
                   sv.lifted->points[3 * i + 2]};
  const Vec3 origin = view.centre_at(x + 0.5, y + 0.5);
  const Vec3 ray_world = Normalized(world - origin);
  const Vec3 normal_world{sv.lifted->normals[3 * shown], sv.lifted->normals[3 * shown + 1],
                          sv.lifted->normals[3 * shown + 2]};
  const Vec3 normal = to_frame.rotation * normal_world;
  const Vec3 ray = to_frame.rotation * ray_world;
  const std::array<float, 6> plucker = PluckerRay(origin, ray_world);
  out->positions.insert(out->positions.end(),
                        {float(c.position.x), float(c.position.y), float(c.position.z)});
  out->rgb.insert(out->rgb.end(),
                  {view.rgb.at(x, y, 0), view.rgb.at(x, y, 1), view.rgb.at(x, y, 2)});
  out->plucker.insert(out->plucker.end(), plucker.begin(), plucker.end());
  out->normals.insert(out->normals.end(), {float(normal.x), float(normal.y), float(normal.z)});
  out->rays.insert(out->rays.end(), {float(ray.x), float(ray.y), float(ray.z)});
  out->depths.push_back(hidden ? c.depth : sv.depth->depth[i]);
  const bool edge = !hidden && options.edge_footprint_scale != 1.0 &&
                    AtNearSideOfEdge(*sv.depth, i, options.behind_min_jump);
  out->footprints.push_back(edge ? float(c.footprint * options.edge_footprint_scale) : c.footprint);
  out->views.push_back(c.view);
  out->pixels.push_back(c.pixel);
  out->owners.push_back(owner);
  out->far.push_back(sv.depth->is_far(shown) ? 1 : 0);
  out->hidden.push_back(hidden ? 1 : 0);
}

// Keeps, per voxel of side `side`, the candidate nearest the voxel centre;
// returns their indices in candidate order.
std::vector<size_t> ThinByVoxel(const std::vector<Candidate>& candidates, double side) {
  absl::flat_hash_map<uint64_t, size_t> best;
  best.reserve(candidates.size());
  auto off_centre = [&](const Vec3& p) {
    const Vec3 c{(std::floor(p.x / side) + 0.5) * side, (std::floor(p.y / side) + 0.5) * side,
                 (std::floor(p.z / side) + 0.5) * side};
    const Vec3 d = p - c;
    return Dot(d, d);
  };
  for (size_t i = 0; i < candidates.size(); ++i) {
    auto [it, inserted] = best.try_emplace(VoxelKey(candidates[i].position, side, 0), i);
    if (!inserted &&
        off_centre(candidates[i].position) < off_centre(candidates[it->second].position))
      it->second = i;
  }
  std::vector<size_t> kept;
  kept.reserve(best.size());
  for (const auto& [key, index] : best) kept.push_back(index);
  std::sort(kept.begin(), kept.end());
  return kept;
}

size_t CountVoxels(const std::vector<Candidate>& candidates, double side) {
  absl::flat_hash_set<uint64_t> keys;
  keys.reserve(candidates.size());
  for (const Candidate& c : candidates) keys.insert(VoxelKey(c.position, side, 0));
  return keys.size();
}

// The dynamic queries of the instance `owner` (track `track`): its boxed
// pixels of every view (`owned`: per view, (owner, pixel) sorted) in its
// canonical frame, thinned to at most options.dynamic_per_instance voxels
// (the smallest voxel side that does, by bisection), each with the
// canonical-from-world change at its pixel's time.
std::vector<std::pair<Candidate, Rigid>> DynamicCandidates(
    const std::vector<SamplingView>& views, const InstanceTrack& track, uint32_t owner,
    const std::vector<std::vector<std::pair<uint32_t, uint32_t>>>& owned,
    const std::vector<PixelFootprints>& footprints, const SamplingOptions& options) {
  std::vector<std::pair<Candidate, Rigid>> chosen;
  if (track.boxes.empty()) return chosen;
  std::vector<Candidate> candidates;
  // Per view, canonical-from-world at its time (at each LineTime of a
  // rolling-shutter view); a pixel takes its line's.
  std::vector<std::vector<Rigid>> to_canonical(views.size());
  auto canonical_of = [&](size_t v, size_t pixel) -> const Rigid& {
    const ContextView& view = *views[v].view;
    return to_canonical[v]
                       [LineTimeSample(view.rolling_shutter, view.width(), view.height(), pixel)];
  };
  for (size_t v = 0; v < views.size(); ++v) {
    const SamplingView& sv = views[v];
    const int samples = sv.view->rolling_shutter.has_value() ? kLineTimeSamples : 1;
    for (int t = 0; t < samples; ++t) {
      to_canonical[v].push_back(
          CanonicalFromWorld(track, LineTime(sv.view->timestamp_us, sv.view->rolling_shutter, t)));
    }
    auto first =
        std::lower_bound(owned[v].begin(), owned[v].end(), std::pair<uint32_t, uint32_t>{owner, 0});
    for (auto it = first; it != owned[v].end() && it->first == owner; ++it) {
      const size_t i = it->second;
      const Vec3 p{sv.lifted->points[3 * i], sv.lifted->points[3 * i + 1],
                   sv.lifted->points[3 * i + 2]};
      candidates.push_back({static_cast<int>(v), static_cast<int>(i), canonical_of(v, i) * p,
                            float(footprints[v].Of(sv.depth->depth[i], i))});
    }
  }
  if (candidates.empty()) return chosen;
  std::vector<size_t> kept;
  double side = 0;
  if (options.dense) {
    kept.resize(candidates.size());
    for (size_t i = 0; i < kept.size(); ++i) kept[i] = i;
  } else {
    std::vector<float> fps;
    for (const Candidate& c : candidates) fps.push_back(c.footprint);
    std::nth_element(fps.begin(), fps.begin() + fps.size() / 2, fps.end());
    double lo = 0.5 * fps[fps.size() / 2], hi = lo;
    const size_t budget = static_cast<size_t>(std::max<int64_t>(1, options.dynamic_per_instance));
    if (CountVoxels(candidates, lo) <= budget) {
      side = lo;
    } else {
      while (CountVoxels(candidates, hi) > budget) hi *= 2;
      for (int iter = 0; iter < 12; ++iter) {
        const double mid = 0.5 * (lo + hi);
        (CountVoxels(candidates, mid) > budget ? lo : hi) = mid;
      }
      side = hi;
    }
    kept = ThinByVoxel(candidates, side);
  }
  chosen.reserve(kept.size());
  for (size_t index : kept) {
    Candidate c = candidates[index];
    c.footprint = std::max(c.footprint, float(side));
    chosen.push_back({c, canonical_of(c.view, c.pixel)});
  }
  return chosen;
}

}  // namespace

int64_t ScaledBudget(int64_t at_768x576, int width, int height) {
  const double scale = double(width) * height / (768.0 * 576.0);
  return std::max<int64_t>(1, static_cast<int64_t>(std::llround(double(at_768x576) * scale)));
}

int64_t ScaledStaticBudget(int64_t at_768x576, int width, int height) {
  const double scale = double(width) * height / (768.0 * 576.0);
  if (scale <= 1.0) return ScaledBudget(at_768x576, width, height);
  return static_cast<int64_t>(std::llround(double(at_768x576) * std::sqrt(scale)));
}

int LineTimeSample(const std::optional<RollingShutter>& rolling_shutter, int width, int height,
                   size_t pixel) {
  if (!rolling_shutter.has_value() || width <= 0) return 0;
  const double f = ReadoutFraction(rolling_shutter->readout, width, height,
                                   static_cast<double>(pixel % width) + 0.5,
                                   static_cast<double>(pixel / width) + 0.5);
  return static_cast<int>(std::lround(f * (kLineTimeSamples - 1)));
}

int64_t LineTime(int64_t timestamp_us, const std::optional<RollingShutter>& rolling_shutter,
                 int sample) {
  if (!rolling_shutter.has_value()) return timestamp_us;
  return timestamp_us + std::llround(static_cast<double>(rolling_shutter->readout_us) * sample /
                                     (kLineTimeSamples - 1));
}

std::vector<uint32_t> PixelOwners(const LiftedView& lifted, const ViewDepth& depth,
                                  const std::vector<InstanceTrack>& tracks, int64_t timestamp_us,
                                  const std::optional<RollingShutter>& rolling_shutter) {
  const size_t n = static_cast<size_t>(lifted.width) * lifted.height;
  std::vector<uint32_t> owners(n, 0);
  if (tracks.empty()) return owners;
  std::vector<BoxesAt> boxes;
  const int samples = rolling_shutter.has_value() ? kLineTimeSamples : 1;
  for (int k = 0; k < samples; ++k) {
    boxes.emplace_back(tracks, LineTime(timestamp_us, rolling_shutter, k));
  }
  DefaultThreadPool().ParallelFor(0, static_cast<int64_t>(n), 8192, [&](int64_t b, int64_t e) {
    for (int64_t i = b; i < e; ++i) {
      if (!lifted.valid[i] || depth.is_far(i)) continue;
      const int k = LineTimeSample(rolling_shutter, lifted.width, lifted.height, size_t(i));
      owners[i] =
          boxes[k].Owner({lifted.points[3 * i], lifted.points[3 * i + 1], lifted.points[3 * i + 2]},
                         kMembershipMargin);
    }
  });
  return owners;
}

namespace {

// Per-view facts for finding the view that sees a point in most detail.
struct ViewResolution {
  Rigid camera_from_world;
  const PixelFootprints* footprints = nullptr;
  double stride = 1;
  std::optional<LinePoses> lines;  // With a rolling shutter.
};

// World point `p` in view `r`'s camera frame (of the line that reads it, with
// a rolling shutter); behind the camera where no line sees it.
Vec3 InCamera(const ViewResolution& r, const Vec3& p) {
  if (!r.lines.has_value()) return r.camera_from_world * p;
  Vec3 pc;
  double u, v;
  return r.lines->Project(p, &u, &v, &pc) ? pc : Vec3{0, 0, -1};
}

// Sets `pixel` to the index of the pixel of `sv` that camera point `pc`
// projects into; false when it projects nowhere or outside the image.
bool PixelOf(const SamplingView& sv, const Vec3& pc, size_t* pixel) {
  double x, y;
  if (!sv.view->camera.Project(pc, &x, &y)) return false;
  int px, py;
  if (!PixelInImage(x, y, sv.depth->width, sv.depth->height, &px, &py)) return false;
  *pixel = static_cast<size_t>(py) * sv.depth->width + px;
  return true;
}

// Returns true if a view other than `self`, at most `max_seconds` from its
// time, sees world point `p` (depth-consistent, in the image) with a
// footprint smaller than `footprint` / `ratio`.
bool FinerViewSees(const Vec3& p, double footprint, size_t self, double ratio, double max_seconds,
                   const std::vector<SamplingView>& views,
                   const std::vector<ViewResolution>& resolution) {
  const int64_t own_time_us = views[self].view->timestamp_us;
  for (size_t u = 0; u < views.size(); ++u) {
    if (u == self) continue;
    if (double(std::abs(views[u].view->timestamp_us - own_time_us)) * 1e-6 > max_seconds) {
      continue;
    }
    const Vec3 pc = InCamera(resolution[u], p);
    if (pc.z <= 0) continue;
    // A pinhole camera's footprint is the same at every pixel: tested
    // before finding the pixel.
    const PixelFootprints& footprints = *resolution[u].footprints;
    if (footprints.pinhole() &&
        footprints.Of(pc.z, 0) * resolution[u].stride * ratio >= footprint) {
      continue;
    }
    size_t j;
    if (!PixelOf(views[u], pc, &j)) continue;
    if (footprints.Of(pc.z, j) * resolution[u].stride * ratio >= footprint) continue;
    // An ego-body pixel shows the body, not the point.
    if (views[u].view->is_ego(j)) continue;
    if (views[u].depth->is_far(j) || (*views[u].owners)[j] != 0) continue;
    if (std::abs(views[u].depth->depth[j] - pc.z) <= 0.03 * pc.z) return true;
  }
  return false;
}

// A view whose depth at a point is at least this share of the point's sees
// it (OtherViewSeesOrPasses).
constexpr double kSeenShare = 0.97;

// Returns true if a view other than `self` sees world point `p` (on the far
// layer when `far`) or sees past it: the pixel it projects to is static and
// shows the far layer, or a surface within 1 - `near_share` of the point's
// depth (the view samples that surface itself; a wider share for a point
// placed on a plane a few centimetres off the surface that view measured), or
// (for a point not on the far layer) one deeper than that (the point is in
// free space).
bool OtherViewSeesOrPasses(const Vec3& p, bool far, size_t self,
                           const std::vector<SamplingView>& views,
                           const std::vector<ViewResolution>& resolution,
                           double near_share = kSeenShare) {
  for (size_t u = 0; u < views.size(); ++u) {
    if (u == self) continue;
    const Vec3 pc = InCamera(resolution[u], p);
    size_t j;
    if (pc.z <= 0 || !PixelOf(views[u], pc, &j)) continue;
    if ((*views[u].owners)[j] != 0 || views[u].view->is_ego(j)) continue;
    if (views[u].depth->is_far(j) || (!far && views[u].depth->depth[j] >= near_share * pc.z)) {
      return true;
    }
  }
  return false;
}

// |cos| between a pixel's ray and its surface normal under which the
// surface is grazing and hides nothing (HiddenCandidate).
constexpr double kMinHiddenFacing = 0.3;

// Which way is up, and how low the scene goes: hidden queries (on surfaces
// nobody saw) are kept above the floor, the 1st percentile of the height of
// every measured point (not far layer) of the views, less 0.5 m; up is the
// mean normal of the surfaces facing about the way the cameras' up axes
// (-y) point, vehicle cameras being mounted about level.
struct HiddenFloor {
  Vec3 up{0, 0, 1};
  double height = -std::numeric_limits<double>::infinity();
};

// Normals within this cosine of the cameras' up count as facing up (30 deg).
constexpr double kGroundCos = 0.866;

HiddenFloor FindHiddenFloor(const std::vector<SamplingView>& views) {
  HiddenFloor floor;
  Vec3 up;
  for (const SamplingView& sv : views)
    up = up + sv.view->world_from_camera.rotation * Vec3{0, -1, 0};
  if (Norm(up) < 1e-9) return floor;
  floor.up = Normalized(up);
  // The cameras' pitch leaves that a few degrees off, tens of metres of
  // height at the far end of the scene: the mean normal of the surfaces
  // that face up (the ground, roofs) is the better estimate.
  Vec3 ground;
  int facing_up = 0;
  for (const SamplingView& sv : views) {
    const size_t pixels = sv.lifted->valid.size();
    for (size_t i = 0; i < pixels; i += 7) {
      if (!sv.lifted->valid[i] || sv.depth->is_far(i)) continue;
      const Vec3 n{sv.lifted->normals[3 * i], sv.lifted->normals[3 * i + 1],
                   sv.lifted->normals[3 * i + 2]};
      if (Dot(n, floor.up) < kGroundCos) continue;
      ground = ground + n;
      ++facing_up;
    }
  }
  if (facing_up >= 100) floor.up = Normalized(ground);
  std::vector<double> heights;
  for (const SamplingView& sv : views) {
    const size_t pixels = sv.lifted->valid.size();
    for (size_t i = 0; i < pixels; i += 7) {  // A sample is plenty for a percentile.
      if (!sv.lifted->valid[i] || sv.depth->is_far(i)) continue;
      heights.push_back(Dot(Vec3{sv.lifted->points[3 * i], sv.lifted->points[3 * i + 1],
                                 sv.lifted->points[3 * i + 2]},
                            floor.up));
    }
  }
  if (heights.empty()) return floor;
  const size_t k = heights.size() / 100;
  std::nth_element(heights.begin(), heights.begin() + k, heights.end());
  floor.height = heights[k] - 0.5;
  return floor;
}

// Returns the hidden query behind pixel `i` of view `v` with background
// pixel `source` (FindBehindSources, -1: none): on the ray through `i`,
// where the plane of the background pixel's surface (its point and normal)
// meets it, or at the background's range when that plane does not give a
// point behind `i`; at the far layer's range for a far background. False
// when there is none: a pixel `i` on the far layer, no background, a
// background that is not static, one whose plane continues through `i`
// itself (a slanted surface, not an occlusion), a pixel `i` whose own
// surface the ray meets at a grazing angle, sky behind a ray that points
// below the horizontal plane, and a point below the floor (HiddenFloor).
// Any depth edge deeper than `min_jump` counts as an occlusion: a surface
// that only recedes (the road up to a wall) is not told from an occluder,
// and the query behind it lies under that surface, above the floor, hidden
// wherever the surface was seen and filling a hole where it was not
// (docs/QUALITY.md, "What was tried and dropped": the occluder rule).
bool HiddenCandidate(const SamplingView& sv, int v, size_t i, int32_t source, double min_jump,
                     const PixelFootprints& footprints, double stride, const HiddenFloor& floor,
                     Candidate* out) {
  if (source < 0 || !sv.lifted->valid[i] || sv.depth->is_far(i)) return false;
  const size_t j = static_cast<size_t>(source);
  if (!sv.lifted->valid[j] || (*sv.owners)[j] != 0) return false;
  const Vec3 origin = sv.view->centre_at(i % sv.view->width() + 0.5, i / sv.view->width() + 0.5);
  const Vec3 p_i{sv.lifted->points[3 * i], sv.lifted->points[3 * i + 1],
                 sv.lifted->points[3 * i + 2]};
  const Vec3 p_j{sv.lifted->points[3 * j], sv.lifted->points[3 * j + 1],
                 sv.lifted->points[3 * j + 2]};
  const double range_i = Norm(p_i - origin), range_j = Norm(p_j - origin);
  if (!(range_i > 0)) return false;
  const Vec3 ray = (p_i - origin) / range_i;
  const Vec3 n_i{sv.lifted->normals[3 * i], sv.lifted->normals[3 * i + 1],
                 sv.lifted->normals[3 * i + 2]};
  if (std::abs(Dot(ray, n_i)) < kMinHiddenFacing) return false;
  double range = range_j;
  if (sv.depth->is_far(j)) {
    // The sky lies above the horizontal plane: below it, what a near
    // surface hides is ground, and a query on the far layer would sit deep
    // underground.
    if (Dot(ray, floor.up) <= 0) return false;
  } else {
    const Vec3 n{sv.lifted->normals[3 * j], sv.lifted->normals[3 * j + 1],
                 sv.lifted->normals[3 * j + 2]};
    const double along = Dot(ray, n);
    if (std::abs(along) > 1e-3) {
      const double s = Dot(p_j - origin, n) / along;
      if (s > 0 && s <= 2 * range_j) range = s;
    }
    if (range <= (1 + min_jump) * range_i) return false;
    if (Dot(origin + range * ray, floor.up) < floor.height) return false;
  }
  const float z = static_cast<float>(sv.depth->depth[i] * range / range_i);
  *out = {v,
          static_cast<int>(i),
          origin + range * ray,
          float(footprints.Of(z, i) * stride),
          static_cast<int>(j),
          z};
  return true;
}

// Per pixel of an ego-body view, the nearest pixel above it in its column
// that is not on the body (-1: none); empty without a body.
std::vector<int32_t> AboveBody(const ContextView& view) {
  if (view.ego.empty()) return {};
  const int w = view.width(), h = view.height();
  std::vector<int32_t> above(size_t(w) * h, -1);
  for (int x = 0; x < w; ++x) {
    int32_t last = -1;
    for (int y = 0; y < h; ++y) {
      const size_t i = size_t(y) * w + x;
      if (!view.is_ego(i)) last = static_cast<int32_t>(i);
      above[i] = last;
    }
  }
  return above;
}

// Another view whose depth there is within this share of a road point
// under the body sees that road (OtherViewSeesOrPasses): the level plane
// the point is put on lies a few centimetres off the road that view
// measured, a few per cent of the depth along a grazing ray.
constexpr double kUnderBodySeen = 0.9;

// The hidden query of ego-body pixel `i` of view `v`: the road the body
// hides, where the level plane of the ground seen above the body's edge in
// the same column (`source`, AboveBody) meets the ray through `i`. When the
// camera moves on, the road just past the body's edge, under the body in
// every CONTEXT view, comes into view. False when `source` is not static
// ground (facing up within 30 degrees of the floor's up), or lies more than
// `band` pixels above `i`, or the ray does not meet that plane ahead.
bool EgoHiddenCandidate(const SamplingView& sv, const LinePoses& lines, int v, size_t i,
                        int32_t source, int band, const PixelFootprints& footprints, double stride,
                        const HiddenFloor& floor, Candidate* out) {
  if (source < 0) return false;
  const ContextView& view = *sv.view;
  const size_t j = static_cast<size_t>(source);
  const int w = view.width();
  if (static_cast<int>(i / w) - static_cast<int>(j / w) > band) return false;
  if (!sv.lifted->valid[j] || (*sv.owners)[j] != 0 || sv.depth->is_far(j)) return false;
  const Vec3 n{sv.lifted->normals[3 * j], sv.lifted->normals[3 * j + 1],
               sv.lifted->normals[3 * j + 2]};
  if (Dot(n, floor.up) < kGroundCos) return false;
  const Vec3 p_j{sv.lifted->points[3 * j], sv.lifted->points[3 * j + 1],
                 sv.lifted->points[3 * j + 2]};
  const double u = double(i % w) + 0.5, y = double(i / w) + 0.5;
  const Vec3 origin = view.centre_at(u, y);
  Vec3 at_unit_z;
  if (!lines.Lift(u, y, 1.0, &at_unit_z)) return false;
  const Vec3 step = at_unit_z - origin;  // One metre of z depth along the ray.
  const double along = Dot(step, floor.up);
  if (!(along < -1e-6)) return false;
  const double z = Dot(p_j - origin, floor.up) / along;
  if (!(z > 0)) return false;
  *out = {v,
          static_cast<int>(j),
          origin + z * step,
          float(footprints.Of(z, i) * stride),
          static_cast<int>(j),
          static_cast<float>(z)};
  return true;
}

// The colour of the hidden query behind pixel `i` with background pixel
// `source`: that of the background nearest `i` in the image, so what
// borders the occluder (a shop window's band, the kerb, the sky) goes on
// into the strip it hides. The deepest pixel of a window (`source`) lies in
// one of its corners, often a storey away: its colour drew streaks of wall
// across shop fronts (docs/QUALITY.md, "The method as built"). Found by
// stepping from `i` in 8 directions up to
// `reach` steps; background is a static pixel on `source`'s layer (far or
// not) deeper than `i` by more than `min_jump`. The first background pixel
// beside an edge mixes in the occluder (antialiasing), so the next one is
// taken instead where it is background too. `source`'s colour when no
// direction meets the background.
std::array<float, 3> BackgroundColour(const SamplingView& sv, size_t i, size_t source, int reach,
                                      double min_jump) {
  const ContextView& view = *sv.view;
  const int w = view.width(), h = view.height();
  const int x0 = static_cast<int>(i % w), y0 = static_cast<int>(i / w);
  const bool far = sv.depth->is_far(source);
  const double deeper = (1 + min_jump) * sv.depth->depth[i];
  auto background = [&](int x, int y) {
    if (x < 0 || y < 0 || x >= w || y >= h) return false;
    const size_t q = static_cast<size_t>(y) * w + x;
    return sv.lifted->valid[q] && (*sv.owners)[q] == 0 && !view.is_ego(q) &&
           sv.depth->is_far(q) == far && (far || sv.depth->depth[q] > deeper);
  };
  constexpr int kDirections[8][2] = {{1, 0}, {-1, 0}, {0, 1},  {0, -1},
                                     {1, 1}, {-1, 1}, {1, -1}, {-1, -1}};
  // Each direction's first background pixel (past its antialiased edge),
  // weighted by 1 / distance^2. The directions are stepped together, and
  // stop at kBlendReach times the nearest one's distance: what lies further
  // would weigh under 1/9 of it.
  constexpr double kBlendReach = 3.0;
  std::array<double, 3> sum{};
  double weight = 0, limit = reach;
  std::array<bool, 8> done{};
  for (int k = 1; k <= reach; ++k) {
    for (int d = 0; d < 8; ++d) {
      const int dx = kDirections[d][0], dy = kDirections[d][1];
      const double distance = (dx != 0 && dy != 0) ? k * std::sqrt(2.0) : double(k);
      if (done[d] || distance > limit) continue;
      int x = x0 + k * dx, y = y0 + k * dy;
      if (!background(x, y)) continue;
      done[d] = true;
      limit = std::min(limit, kBlendReach * distance);
      if (background(x + dx, y + dy)) x += dx, y += dy;
      const double wd = 1.0 / (distance * distance);
      for (int c = 0; c < 3; ++c) sum[c] += wd * view.rgb.at(x, y, c);
      weight += wd;
    }
    if (k > limit) break;
  }
  if (weight == 0) {
    const int x = static_cast<int>(source % w), y = static_cast<int>(source / w);
    return {view.rgb.at(x, y, 0), view.rgb.at(x, y, 1), view.rgb.at(x, y, 2)};
  }
  return {float(sum[0] / weight), float(sum[1] / weight), float(sum[2] / weight)};
}

// The direction the context cameras travel in: their velocity, the
// least-squares slope of their positions over time, as a unit vector; zero
// when at that velocity they travel less than kMinTravel over the views' time
// span (a parked car's pose jitter, a rig's cameras firing a few ms apart).
Vec3 RoadDirection(const std::vector<SamplingView>& views) {
  constexpr double kMinTravel = 1.0;  // Metres.
  Vec3 mean_position;
  double mean_time = 0, first = std::numeric_limits<double>::infinity(), last = -first;
  for (const SamplingView& sv : views) {
    const double t = 1e-6 * double(sv.view->timestamp_us);
    mean_position = mean_position + sv.view->world_from_camera.translation;
    mean_time += t;
    first = std::min(first, t);
    last = std::max(last, t);
  }
  mean_position = mean_position / double(views.size());
  mean_time /= double(views.size());
  Vec3 moment;
  double spread = 0;
  for (const SamplingView& sv : views) {
    const double dt = 1e-6 * double(sv.view->timestamp_us) - mean_time;
    moment = moment + (sv.view->world_from_camera.translation - mean_position) * dt;
    spread += dt * dt;
  }
  if (!(spread > 0)) return Vec3{};
  const Vec3 velocity = moment / spread;
  return Norm(velocity) * (last - first) >= kMinTravel ? Normalized(velocity) : Vec3{};
}

// What the views saw, for the colours of hidden queries (Colour): the
// visible static queries off the far layer, averaged per voxel of side
// kSurfelSide and per normal direction (rounded to a 5x5x5 lattice, so a
// voxel where a wall meets the road keeps both), searched in a frame where
// distances along the road are scaled by `road_scale`. A query whose pixel
// borders a nearer surface is left out: its colour mixes in the occluder
// (antialiasing), which would run into every strip that occluder hides.
class SeenSurfaces {
 public:
  SeenSurfaces(const QuerySet& queries, const std::vector<SamplingView>& views, double min_jump,
               const Vec3& road, double road_scale) {
    if (Norm(road) > 0.5) {
      scale_ = std::clamp(road_scale, kMinRoadScale, 1.0);
      e1_ = road;
      e2_ = Normalized(std::abs(road.z) < 0.9 ? Cross(road, Vec3{0, 0, 1})
                                              : Cross(road, Vec3{1, 0, 0}));
      e3_ = Cross(e1_, e2_);
    }
    struct Sum {
      Vec3 position, normal;
      std::array<double, 3> rgb{};
      double count = 0;
    };
    // Each query's surfel key (kLeftOut: none), found in parallel; summed
    // in query order.
    constexpr uint64_t kLeftOut = UINT64_MAX;  // Direction 127 is not on the lattice.
    std::vector<uint64_t> keys(queries.size(), kLeftOut);
    DefaultThreadPool().ParallelFor(
        0, static_cast<int64_t>(queries.size()), 16384, [&](int64_t begin, int64_t end) {
          for (int64_t q = begin; q < end; ++q) {
            const size_t i = static_cast<size_t>(q);
            if (queries.is_hidden(i) || queries.far[i] || queries.owners[i] != 0) continue;
            if (BordersNearer(views[queries.views[i]], queries.pixels[i], min_jump)) continue;
            const Vec3 n = queries.normal(i);
            auto lattice = [](double v) { return static_cast<uint64_t>(std::lround(2 * v) + 2); };
            const uint64_t direction = lattice(n.x) * 25 + lattice(n.y) * 5 + lattice(n.z);
            keys[i] = VoxelKey(queries.position(i), kSurfelSide, 0) ^ (direction << 57);
          }
        });
    absl::flat_hash_map<uint64_t, Sum> sums;
    for (size_t i = 0; i < queries.size(); ++i) {
      if (keys[i] == kLeftOut) continue;
      const Vec3 p = queries.position(i), n = queries.normal(i);
      Sum& sum = sums[keys[i]];
      sum.position = sum.position + p;
      sum.normal = sum.normal + n;
      for (int c = 0; c < 3; ++c) sum.rgb[c] += queries.rgb[3 * i + c];
      sum.count += 1;
    }
    // (search cell, surfel key, surfel), sorted: by cell, and within a cell
    // in an order that does not depend on the hash map's (the blend's sums
    // should not either).
    std::vector<std::tuple<uint64_t, uint64_t, Surfel>> keyed;
    keyed.reserve(sums.size());
    for (const auto& [key, sum] : sums) {
      if (Norm(sum.normal) < 1e-9) continue;
      const Surfel surfel{sum.position / sum.count,
                          Normalized(sum.normal),
                          {float(sum.rgb[0] / sum.count), float(sum.rgb[1] / sum.count),
                           float(sum.rgb[2] / sum.count)}};
      keyed.emplace_back(VoxelKey(Scaled(surfel.position), kCell, 0), key, surfel);
    }
    std::sort(keyed.begin(), keyed.end(), [](const auto& a, const auto& b) {
      return std::tie(std::get<0>(a), std::get<1>(a)) < std::tie(std::get<0>(b), std::get<1>(b));
    });
    surfels_.reserve(keyed.size());
    scaled_.reserve(keyed.size());
    for (size_t k = 0; k < keyed.size(); ++k) {
      surfels_.push_back(std::get<2>(keyed[k]));
      scaled_.push_back(Scaled(surfels_.back().position));
      auto [it, inserted] = cells_.try_emplace(std::get<0>(keyed[k]), uint32_t(k), uint32_t(k));
      it->second.second = static_cast<uint32_t>(k + 1);
    }
  }

  // The colour around `p` on the plane through it of normal `n`: a blend,
  // weighted 1 / (d^2 + kSurfelSide^2), of the kNeighbours nearest surfels
  // (d in the scaled frame) that face within kMinCos of `n` and lie within
  // kPlaneTolerance of the plane, looked for within kRings x kCell of `p`
  // in the scaled frame. False when there is none.
  bool Colour(const Vec3& p, const Vec3& n, std::array<float, 3>* rgb) const {
    std::array<std::pair<double, uint32_t>, kNeighbours> nearest;
    int found = 0;
    const Vec3 ps = Scaled(p);
    const int64_t cx = static_cast<int64_t>(std::floor(ps.x / kCell));
    const int64_t cy = static_cast<int64_t>(std::floor(ps.y / kCell));
    const int64_t cz = static_cast<int64_t>(std::floor(ps.z / kCell));
    // How far a cell's points can lie from its centre along `n`.
    const double reach =
        0.5 * kCell *
        (std::abs(Dot(n, e1_)) / scale_ + std::abs(Dot(n, e2_)) + std::abs(Dot(n, e3_)));
    // The plane test below is linear in a cell's scaled centre: per row of
    // cells, its dx where it can pass (a cell wider on both sides, for
    // rounding) bounds the cells tested; the test itself decides.
    const Vec3 along{Dot(e1_, n) / scale_, Dot(e2_, n), Dot(e3_, n)};
    const double slope = kCell * along.x;
    auto row_range = [&](int64_t dy, int64_t dz, int r, int* lo, int* hi) {
      const double offset = (cx + 0.5) * kCell * along.x + (cy + dy + 0.5) * kCell * along.y +
                            (cz + dz + 0.5) * kCell * along.z - Dot(p, n);
      const double bound = reach + kPlaneTolerance;
      *lo = -r;
      *hi = r;
      if (std::abs(slope) < 1e-9) {
        if (std::abs(offset) > bound + 1e-6) *lo = r + 1;
        return;
      }
      const double a = (-bound - offset) / slope, b = (bound - offset) / slope;
      const double first = std::floor(std::min(a, b)) - 1, last = std::ceil(std::max(a, b)) + 1;
      if (first > -r) *lo = first > r ? r + 1 : static_cast<int>(first);
      if (last < r) *hi = last < -r ? -r - 1 : static_cast<int>(last);
    };
    for (int r = 0; r <= kRings; ++r) {
      // The cells at Chebyshev distance r: whole rows on the faces of the
      // cube, the two ends of each row inside it.
      for (int dz = -r; dz <= r; ++dz) {
        for (int dy = -r; dy <= r; ++dy) {
          const bool face = r == 0 || std::abs(dz) == r || std::abs(dy) == r;
          int lo, hi;
          row_range(dy, dz, r, &lo, &hi);
          for (int dx = -r; dx <= r; dx += face ? 1 : 2 * r) {
            if (dx < lo) {
              if (!face) continue;
              dx = lo;
            }
            if (dx > hi) break;
            const Vec3 centre{(cx + dx + 0.5) * kCell, (cy + dy + 0.5) * kCell,
                              (cz + dz + 0.5) * kCell};
            if (std::abs(Dot(Unscaled(centre) - p, n)) > reach + kPlaneTolerance) continue;
            // A cell no nearer than the farthest of kNeighbours found holds
            // none that would replace it.
            if (found == kNeighbours && CellDistance2(ps, centre) >= nearest[0].first) continue;
            const auto it = cells_.find(VoxelKey(centre, kCell, 0));
            if (it == cells_.end()) continue;
            for (uint32_t k = it->second.first; k < it->second.second; ++k) {
              const Surfel& s = surfels_[k];
              const Vec3 d = s.position - p;
              if (Dot(s.normal, n) < kMinCos || std::abs(Dot(d, n)) > kPlaneTolerance) continue;
              const Vec3 ds = scaled_[k] - ps;
              const double d2 = Dot(ds, ds);
              // A ball, not the cube of cells: the next ring, not searched,
              // may hold nearer surfels than a corner of the last one.
              if (d2 > kReach * kReach) continue;
              if (found < kNeighbours) {
                nearest[found++] = {d2, k};
                std::push_heap(nearest.begin(), nearest.begin() + found);
              } else if (d2 < nearest[0].first) {
                std::pop_heap(nearest.begin(), nearest.end());
                nearest.back() = {d2, k};
                std::push_heap(nearest.begin(), nearest.end());
              }
            }
          }
        }
      }
      // Whatever the next ring holds is at least r cells away.
      if (found == kNeighbours && nearest[0].first < (r * kCell) * (r * kCell)) break;
    }
    if (found == 0) return false;
    std::array<double, 3> sum{};
    double weight = 0;
    for (int k = 0; k < found; ++k) {
      const double w = 1.0 / (nearest[k].first + kSurfelSide * kSurfelSide);
      for (int c = 0; c < 3; ++c) sum[c] += w * surfels_[nearest[k].second].rgb[c];
      weight += w;
    }
    for (int c = 0; c < 3; ++c) (*rgb)[c] = float(sum[c] / weight);
    return true;
  }

 private:
  struct Surfel {
    Vec3 position;  // World.
    Vec3 normal;
    std::array<float, 3> rgb;
  };
  static constexpr double kSurfelSide = 0.1;      // Metres.
  static constexpr double kCell = 0.8;            // Search cells, metres of the scaled frame.
  static constexpr int kRings = 6;                // Cells searched around a query's.
  static constexpr int kNeighbours = 16;          // Surfels blended.
  static constexpr double kPlaneTolerance = 0.2;  // Metres off the query's plane.
  static constexpr double kMinCos = 0.8;          // Between the normals.
  static constexpr double kReach = kRings * kCell;
  static constexpr double kMinRoadScale = 0.01;

  // True if pixel `i` of `sv` has a neighbour (3x3) nearer by more than
  // `min_jump` (relative).
  static bool BordersNearer(const SamplingView& sv, int i, double min_jump) {
    const int w = sv.depth->width, h = sv.depth->height;
    const int x = i % w, y = i / w;
    const float nearer = static_cast<float>(sv.depth->depth[i] / (1 + min_jump));
    for (int v = std::max(0, y - 1); v <= std::min(h - 1, y + 1); ++v)
      for (int u = std::max(0, x - 1); u <= std::min(w - 1, x + 1); ++u)
        if (const float d = sv.depth->depth[static_cast<size_t>(v) * w + u]; d > 0 && d < nearer) {
          return true;
        }
    return false;
  }
  Vec3 Scaled(const Vec3& p) const { return {scale_ * Dot(p, e1_), Dot(p, e2_), Dot(p, e3_)}; }
  // The squared distance from `q` to the search cell centred at `centre`
  // (both in the scaled frame), less a nanometre for rounding.
  static double CellDistance2(const Vec3& q, const Vec3& centre) {
    double sum = 0;
    for (int a = 0; a < 3; ++a) {
      const double gap = std::max(0.0, std::abs(q[a] - centre[a]) - 0.5 * kCell - 1e-9);
      sum += gap * gap;
    }
    return sum;
  }
  Vec3 Unscaled(const Vec3& q) const { return e1_ * (q.x / scale_) + e2_ * q.y + e3_ * q.z; }

  double scale_ = 1;
  Vec3 e1_{1, 0, 0}, e2_{0, 1, 0}, e3_{0, 0, 1};
  std::vector<Surfel> surfels_;
  std::vector<Vec3> scaled_;  // Scaled(position) of each surfel.
  absl::flat_hash_map<uint64_t, std::pair<uint32_t, uint32_t>> cells_;
};

// The view's N_s (SamplingView::static_density).
double StaticBudget(const SamplingView& sv, const SamplingOptions& options) {
  return double(std::max<int64_t>(1, options.static_per_view)) * std::max(1e-6, sv.static_density);
}

double StaticStride(const SamplingView& sv, const SamplingOptions& options) {
  if (options.dense) return 1.0;
  const double pixels = double(sv.view->width()) * sv.view->height();
  return std::max(1.0, std::sqrt(pixels / StaticBudget(sv, options)));
}

// Appends the static queries of `views` to `out`, with every view's grid
// cell side multiplied by `refine`, hidden ones kept above `floor` and their
// colours to find to `colours`; returns how many visible (not hidden)
// queries were added.
size_t SampleStatic(const std::vector<SamplingView>& views,
                    const std::vector<PixelFootprints>& footprints, const SamplingOptions& options,
                    double refine, const HiddenFloor& floor, QuerySet* out,
                    std::vector<HiddenColour>* colours) {
  size_t visible = 0;
  const Rigid identity;
  std::vector<ViewResolution> resolution(views.size());
  for (size_t v = 0; v < views.size(); ++v) {
    const double stride = StaticStride(views[v], options);
    resolution[v] = {views[v].view->world_from_camera.Inverse(), &footprints[v],
                     options.dense ? stride : std::max(1.0, stride * refine)};
    if (views[v].view->rolling_shutter.has_value()) resolution[v].lines = views[v].view->lines();
  }
  const bool prefer_finer = !options.dense && options.finer_view_ratio > 0;
  absl::flat_hash_set<uint64_t> covered;
  for (size_t v = 0; v < views.size(); ++v) {
    const SamplingView& sv = views[v];
    const int w = sv.view->width(), h = sv.view->height();
    const double stride = resolution[v].stride;
    const int cells_x = static_cast<int>(std::ceil(w / stride));
    const int cells_y = static_cast<int>(std::ceil(h / stride));
    const int far_stride = options.dense ? 1 : std::max(1, options.far_stride);
    std::vector<uint64_t> new_keys;
    const BehindSources behind =
        FindBehindSources(*sv.depth, options.behind_band_px, options.behind_min_jump);
    const std::vector<int32_t> above_body =
        options.behind_band_px > 0 ? AboveBody(*sv.view) : std::vector<int32_t>{};
    const LinePoses view_lines = sv.view->lines();
    // Hidden queries are taken on a grid of behind_stride cells, and behind
    // far-layer backgrounds on the far layer's (a multiple of it).
    const int behind_stride = std::max(1, options.behind_stride);
    const int far_hidden_stride =
        behind_stride * std::max(1, (far_stride + behind_stride - 1) / behind_stride);
    // The cells' choices are made in parallel (they read `covered` as the
    // earlier views left it), then emitted in cell order.
    struct Choice {
      size_t pixel = 0;
      bool hidden = false, visible = false;
      Candidate hidden_query, visible_query;
      int hidden_radius = 0;
      std::optional<uint64_t> hidden_key, visible_key;
    };
    std::vector<std::vector<Choice>> rows(static_cast<size_t>(cells_y));
    DefaultThreadPool().ParallelFor(0, cells_y, 4, [&](int64_t row_begin, int64_t row_end) {
      for (int cy = static_cast<int>(row_begin); cy < row_end; ++cy) {
        for (int cx = 0; cx < cells_x; ++cx) {
          int x = cx, y = cy;
          if (!options.dense) {
            x = CellPixel(cx, stride, Hash01(cx, cy, 2 * v), w);
            y = CellPixel(cy, stride, Hash01(cx, cy, 2 * v + 1), h);
          }
          const size_t i = static_cast<size_t>(y) * w + x;
          Choice choice;
          choice.pixel = i;
          // The nearest background hidden behind this pixel, if no view sees it.
          Candidate& hidden = choice.hidden_query;
          bool has_hidden = false;
          int hidden_radius = 0;
          const bool on_hidden_grid = cx % behind_stride == 0 && cy % behind_stride == 0;
          for (size_t k = 0; on_hidden_grid && k < behind.sources.size(); ++k) {
            has_hidden =
                HiddenCandidate(sv, static_cast<int>(v), i, behind.sources[k][i],
                                options.behind_min_jump, footprints[v], stride, floor, &hidden);
            hidden_radius = behind.radii[k];
            if (has_hidden) break;
          }
          const bool under_body =
              !has_hidden && on_hidden_grid && !above_body.empty() && sv.view->is_ego(i);
          if (under_body) {
            has_hidden =
                EgoHiddenCandidate(sv, view_lines, static_cast<int>(v), i, above_body[i],
                                   options.behind_band_px, footprints[v], stride, floor, &hidden);
            if (has_hidden) hidden_radius = static_cast<int>(i / w) - above_body[i] / w;
          }
          if (has_hidden) {
            // Coarser than visible surfaces: a hidden query copies one
            // background colour, there is no detail to sample.
            const bool far = sv.depth->is_far(static_cast<size_t>(hidden.source_pixel));
            const int hidden_stride = far ? far_hidden_stride : behind_stride;
            bool keep = cx % hidden_stride == 0 && cy % hidden_stride == 0;
            hidden.footprint *= hidden_stride;
            keep = keep && !OtherViewSeesOrPasses(hidden.position, far, v, views, resolution,
                                                  under_body ? kUnderBodySeen : kSeenShare);
            if (keep && options.skip_covered && !options.dense) {
              const uint32_t level = FootprintLevel(hidden.footprint);
              const uint64_t key = VoxelKey(hidden.position, LevelSide(level), level);
              keep = !covered.contains(key);
              if (keep) choice.hidden_key = key;
            }
            choice.hidden = keep;
            choice.hidden_radius = hidden_radius;
          }
          choice.visible = [&] {
            if (!sv.lifted->valid[i] || (*sv.owners)[i] != 0) return false;
            double footprint = footprints[v].Of(sv.depth->depth[i], i) * stride;
            if (sv.depth->is_far(i)) {
              if (cx % far_stride != 0 || cy % far_stride != 0) return false;
              footprint *= far_stride;
            }
            const Vec3 p{sv.lifted->points[3 * i], sv.lifted->points[3 * i + 1],
                         sv.lifted->points[3 * i + 2]};
            if (prefer_finer && !sv.depth->is_far(i) &&
                FinerViewSees(p, footprint, v, options.finer_view_ratio, options.finer_view_seconds,
                              views, resolution)) {
              return false;
            }
            if (options.skip_covered && !options.dense) {
              const uint32_t level = FootprintLevel(footprint);
              const uint64_t key = VoxelKey(p, LevelSide(level), level);
              if (covered.contains(key)) return false;
              choice.visible_key = key;
            }
            choice.visible_query = {static_cast<int>(v), static_cast<int>(i), p, float(footprint)};
            return true;
          }();
          if (choice.hidden || choice.visible) rows[cy].push_back(choice);
        }
      }
    });
    for (const std::vector<Choice>& row : rows) {
      for (const Choice& choice : row) {
        if (choice.hidden) {
          if (choice.hidden_key.has_value()) new_keys.push_back(*choice.hidden_key);
          // The source lies within hidden_radius (Chebyshev): the nearest
          // background within twice that.
          colours->push_back({out->size(), static_cast<int>(v), choice.pixel,
                              static_cast<size_t>(choice.hidden_query.source_pixel),
                              2 * choice.hidden_radius + 1});
          Emit(choice.hidden_query, sv, 0, identity, options, out);
        }
        if (choice.visible) {
          if (choice.visible_key.has_value()) new_keys.push_back(*choice.visible_key);
          Emit(choice.visible_query, sv, 0, identity, options, out);
          ++visible;
        }
      }
    }
    covered.insert(new_keys.begin(), new_keys.end());
  }
  return visible;
}

}  // namespace

std::vector<bool> StillCameraViews(const std::vector<ContextView>& views) {
  std::vector<bool> still(views.size(), false);
  std::map<std::string, std::vector<size_t>> by_camera;
  for (size_t v = 0; v < views.size(); ++v) by_camera[views[v].camera_id].push_back(v);
  for (const auto& [camera, members] : by_camera) {
    if (members.size() < 2) continue;
    const Rigid& first = views[members.front()].world_from_camera;
    const Quat first_rotation = FromMatrix(first.rotation);
    const bool stands = std::all_of(members.begin(), members.end(), [&](size_t v) {
      const Rigid& pose = views[v].world_from_camera;
      return WithinStillReach(first.translation, first_rotation, pose.translation,
                              FromMatrix(pose.rotation));
    });
    if (stands) {
      for (size_t v : members) still[v] = true;
    }
  }
  return still;
}

QuerySet SampleQueries(const std::vector<SamplingView>& views,
                       const std::vector<InstanceTrack>& tracks, const SamplingOptions& options) {
  QuerySet out;
  using Clock = std::chrono::steady_clock;
  auto ms_since = [](Clock::time_point start) {
    return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
  };
  const Clock::time_point start = Clock::now();
  // Static queries, view by view; then, if redundancy removal left fewer
  // than V x N_s, once more on grids refined to make up the difference.
  // The floor depends on the views alone: found once for both passes.
  const HiddenFloor floor = options.behind_band_px > 0 ? FindHiddenFloor(views) : HiddenFloor{};
  std::vector<HiddenColour> colours;
  std::vector<PixelFootprints> footprints;
  footprints.reserve(views.size());
  for (const SamplingView& sv : views) footprints.emplace_back(sv.view->camera);
  const size_t kept = SampleStatic(views, footprints, options, 1.0, floor, &out, &colours);
  double budget = 0;
  for (const SamplingView& sv : views) budget += StaticBudget(sv, options);
  if (options.fill_static_budget && !options.dense && kept > 0 && kept < 0.95 * budget) {
    const double refine =
        std::max(1 / std::sqrt(options.max_refill), std::sqrt(double(kept) / budget));
    out = QuerySet();
    colours.clear();
    SampleStatic(views, footprints, options, refine, floor, &out, &colours);
  }
  const double static_ms = ms_since(start);
  const Clock::time_point surfaces_start = Clock::now();
  std::optional<SeenSurfaces> seen;
  if (options.hidden_colour_from_surfaces && !colours.empty()) {
    seen.emplace(out, views, options.behind_min_jump, RoadDirection(views),
                 options.hidden_road_scale);
  }
  const double surfaces_ms = ms_since(surfaces_start);
  const Clock::time_point hidden_start = Clock::now();
  DefaultThreadPool().ParallelFor(
      0, static_cast<int64_t>(colours.size()), 256, [&](int64_t begin, int64_t end) {
        for (int64_t k = begin; k < end; ++k) {
          const HiddenColour& h = colours[static_cast<size_t>(k)];
          std::array<float, 3> rgb;
          if (!seen || out.far[h.query] ||
              !seen->Colour(out.position(h.query), out.normal(h.query), &rgb)) {
            rgb = BackgroundColour(views[h.view], h.pixel, h.source, h.reach,
                                   options.behind_min_jump);
          }
          std::copy(rgb.begin(), rgb.end(), out.rgb.begin() + 3 * h.query);
        }
      });

  const double hidden_ms = ms_since(hidden_start);
  const Clock::time_point dynamic_start = Clock::now();
  // Dynamic queries, instance by instance, in canonical frames; each
  // view's boxed pixels as (owner, pixel), sorted, so an instance visits
  // its own pixels alone, in pixel order.
  std::vector<std::vector<std::pair<uint32_t, uint32_t>>> owned(views.size());
  if (!tracks.empty()) {
    DefaultThreadPool().ParallelFor(
        0, static_cast<int64_t>(views.size()), 1, [&](int64_t begin, int64_t end) {
          for (int64_t v = begin; v < end; ++v) {
            const std::vector<uint32_t>& owners = *views[v].owners;
            for (size_t i = 0; i < owners.size(); ++i) {
              if (owners[i] != 0) owned[v].push_back({owners[i], static_cast<uint32_t>(i)});
            }
            std::sort(owned[v].begin(), owned[v].end());
          }
        });
  }
  // Each track's queries are chosen on its own (tracks in parallel), then
  // written in track order.
  std::vector<std::vector<std::pair<Candidate, Rigid>>> chosen(tracks.size());
  DefaultThreadPool().ParallelFor(
      0, static_cast<int64_t>(tracks.size()), 1, [&](int64_t begin, int64_t end) {
        for (int64_t k = begin; k < end; ++k) {
          chosen[k] = DynamicCandidates(views, tracks[k], static_cast<uint32_t>(k + 1), owned,
                                        footprints, options);
        }
      });
  for (size_t k = 0; k < tracks.size(); ++k) {
    for (const auto& [c, to_frame] : chosen[k]) {
      Emit(c, views[c.view], static_cast<uint32_t>(k + 1), to_frame, options, &out);
    }
  }
  spdlog::debug(
      "sample: static {:.0f} ms, seen surfaces {:.0f} ms, hidden colours {:.0f} ms ({} queries), "
      "dynamic {:.0f} ms",
      static_ms, surfaces_ms, hidden_ms, colours.size(), ms_since(dynamic_start));
  return out;
}

}  // namespace pf
