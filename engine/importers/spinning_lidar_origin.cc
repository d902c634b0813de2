// Spinning-LiDAR centre from column-mates' elevation differences
// (spinning_lidar_origin.h).
#include "engine/importers/spinning_lidar_origin.h"

#include <cmath>
#include <vector>

#include "common/thread_pool.h"

namespace pf {
namespace {

constexpr double kMaxPairSeconds = 25e-6;
constexpr double kMaxPairAzimuthDeg = 0.5;
// The search box: +-kMaxAcross across the spin axis, [kMinUp, kMaxUp] along it.
constexpr double kMaxAcross = 1.5, kMinUp = -1.0, kMaxUp = 3.0;
constexpr double kMinRange = 3.0;
constexpr double kMinRangeRatio = 1.5;
// The histogram of elevation differences: 0.01 degree bins over +-10 degrees.
constexpr double kBinDeg = 0.01;
constexpr double kSpanDeg = 10.0;

struct PointPair {
  Vec3 a, b;
};

double HorizontalRange(const Vec3& p) { return std::hypot(p.x, p.y); }

// The sum of squared shares of `values` (degrees) in kBinDeg bins over
// +-kSpanDeg: 1 when all fall in one bin; values outside are not counted.
double HistogramConcentration(const std::vector<double>& values) {
  const int bins = static_cast<int>(std::lround(2 * kSpanDeg / kBinDeg));
  std::vector<int> histogram(bins, 0);
  int64_t counted = 0;
  for (double value : values) {
    const int bin = static_cast<int>(std::floor((value + kSpanDeg) / kBinDeg));
    if (bin < 0 || bin >= bins) continue;
    ++histogram[bin];
    ++counted;
  }
  if (counted == 0) return 0;
  double sum = 0;
  for (int count : histogram) sum += double(count) * count;
  return sum / (double(counted) * double(counted));
}

// How tightly the pairs' elevation differences, and their azimuth
// differences, gather seen from `centre` (the product of the two
// concentrations): a column's lasers share their elevation spacings and,
// up to fixed offsets, their azimuth.
double Concentration(const std::vector<PointPair>& pairs, const Vec3& centre) {
  std::vector<double> elevation(pairs.size()), azimuth(pairs.size());
  for (size_t k = 0; k < pairs.size(); ++k) {
    const Vec3 a = pairs[k].a - centre, b = pairs[k].b - centre;
    elevation[k] = (std::atan2(a.z, HorizontalRange(a)) - std::atan2(b.z, HorizontalRange(b))) *
                   kDegreesPerRadian;
    double d = (std::atan2(a.y, a.x) - std::atan2(b.y, b.x)) * kDegreesPerRadian;
    if (d > 180) d -= 360;
    if (d < -180) d += 360;
    azimuth[k] = d;
  }
  return HistogramConcentration(elevation) * HistogramConcentration(azimuth);
}

// The best of a grid of centres around `middle`: `steps` each way of `step`
// across (x, y) and of `step_z` along z, z within [z_min, z_max].
Vec3 BestOnGrid(const std::vector<PointPair>& pairs, const Vec3& middle, int steps, double step,
                int steps_z, double step_z, double z_min, double z_max, double* best_score) {
  std::vector<Vec3> centres;
  for (int i = -steps; i <= steps; ++i)
    for (int j = -steps; j <= steps; ++j)
      for (int k = -steps_z; k <= steps_z; ++k) {
        const Vec3 c{middle.x + i * step, middle.y + j * step, middle.z + k * step_z};
        if (c.z < z_min - 1e-9 || c.z > z_max + 1e-9 || std::abs(c.x) > kMaxAcross + 1e-9 ||
            std::abs(c.y) > kMaxAcross + 1e-9) {
          continue;
        }
        centres.push_back(c);
      }
  std::vector<double> scores(centres.size());
  DefaultThreadPool().ParallelFor(0, static_cast<int64_t>(centres.size()), 16,
                                  [&](int64_t b, int64_t e) {
                                    for (int64_t c = b; c < e; ++c)
                                      scores[c] = Concentration(pairs, centres[c]);
                                  });
  size_t best = 0;
  for (size_t c = 1; c < centres.size(); ++c)
    if (scores[c] > scores[best]) best = c;  // Ties: the first in grid order.
  *best_score = scores[best];
  return centres[best];
}

}  // namespace

LidarOriginEstimate EstimateSpinningLidarOrigin(
    const std::vector<std::vector<FiredPoint>>& sweeps) {
  std::vector<PointPair> pairs;
  for (const std::vector<FiredPoint>& sweep : sweeps) {
    for (size_t i = 0; i + 1 < sweep.size(); ++i) {
      const FiredPoint &p = sweep[i], &q = sweep[i + 1];
      if (!(std::abs(q.time_s - p.time_s) < kMaxPairSeconds)) continue;
      const double rp = HorizontalRange(p.position), rq = HorizontalRange(q.position);
      if (rp < kMinRange || rq < kMinRange) continue;
      if (std::max(rp, rq) < kMinRangeRatio * std::min(rp, rq)) continue;
      // Column-mates share an azimuth seen from the head; seen from the
      // frame's origin, a head up to kMaxAcross away parts them by up to
      // kMaxAcross |1/rp - 1/rq| radians.
      double azimuth = std::abs(std::atan2(p.position.y, p.position.x) -
                                std::atan2(q.position.y, q.position.x)) *
                       kDegreesPerRadian;
      if (azimuth > 180) azimuth = 360 - azimuth;
      if (azimuth >
          kMaxPairAzimuthDeg + kMaxAcross * std::abs(1 / rp - 1 / rq) * kDegreesPerRadian) {
        continue;
      }
      pairs.push_back({p.position, q.position});
    }
  }
  LidarOriginEstimate out;
  out.pairs = static_cast<int64_t>(pairs.size());
  if (pairs.empty()) return out;
  out.concentration_at_origin = Concentration(pairs, Vec3{0, 0, 0});
  double score = 0;
  Vec3 centre = BestOnGrid(pairs, {0, 0, 1}, 10, 0.15, 20, 0.1, kMinUp, kMaxUp, &score);
  centre = BestOnGrid(pairs, centre, 5, 0.03, 5, 0.02, kMinUp, kMaxUp, &score);
  centre = BestOnGrid(pairs, centre, 3, 0.01, 3, 0.01, kMinUp, kMaxUp, &score);
  out.concentration = score;
  out.reliable = out.pairs >= kMinLidarOriginPairs && out.concentration_at_origin > 0 &&
                 score >= 2 * out.concentration_at_origin;
  if (out.reliable) out.centre = centre;
  return out;
}

}  // namespace pf
