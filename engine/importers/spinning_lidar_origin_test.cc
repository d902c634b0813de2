// Tests of the spinning-LiDAR centre estimate: a simulated 32-beam head at a
// known place in a street of a road and two walls, its returns in firing
// order; and sweeps that cannot locate it.
#include "engine/importers/spinning_lidar_origin.h"

#include <gtest/gtest.h>

#include <cmath>
#include <optional>
#include <random>
#include <vector>

namespace pf {
namespace {

// A street: the road z = 0, walls along x whose distance varies with x
// (setbacks), and 40 boxes (cars, kiosks, poles) at random places 4-40 m
// away. Hit() returns the first surface a ray meets, none beyond 80 m.
struct Street {
  struct Box {
    double x0, x1, y0, y1, top;
  };
  std::vector<Box> boxes;
  explicit Street(uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> along(-40, 40), across(-5.5, 8.5), size(0.3, 4),
        top(0.8, 3.5);
    while (boxes.size() < 40) {
      const double x = along(rng), y = across(rng), w = size(rng), d = size(rng);
      if (std::hypot(x, y) < 4) continue;
      boxes.push_back({x, x + w, y, y + std::min(d, 2.0), top(rng)});
    }
  }
  static double LeftWall(double x) { return 9 + 3 * std::sin(x / 7); }
  static double RightWall(double x) { return -6 - 2 * std::cos(x / 5); }

  std::optional<Vec3> Hit(const Vec3& from, const Vec3& dir) const {
    double best = 80;
    if (dir.z < 0) best = std::min(best, -from.z / dir.z);
    // Walls: march (they bend), then boxes exactly.
    for (double t = 0.2; t < best; t += 0.05) {
      const Vec3 p = from + t * dir;
      if (p.y >= LeftWall(p.x) || p.y <= RightWall(p.x)) {
        best = t;
        break;
      }
    }
    for (const Box& b : boxes) {
      // Slab test against the box [x0, x1] x [y0, y1] x [0, top].
      double t0 = 0.1, t1 = best;
      const double lo[3] = {b.x0, b.y0, 0}, hi[3] = {b.x1, b.y1, b.top};
      const double o[3] = {from.x, from.y, from.z}, d[3] = {dir.x, dir.y, dir.z};
      bool hit = true;
      for (int k = 0; k < 3 && hit; ++k) {
        if (std::abs(d[k]) < 1e-12) {
          hit = o[k] >= lo[k] && o[k] <= hi[k];
          continue;
        }
        double a = (lo[k] - o[k]) / d[k], c = (hi[k] - o[k]) / d[k];
        if (a > c) std::swap(a, c);
        t0 = std::max(t0, a);
        t1 = std::min(t1, c);
        hit = t0 <= t1;
      }
      if (hit) best = std::min(best, t0);
    }
    if (best >= 80) return std::nullopt;
    return from + best * dir;
  }
};

// A sweep of a head at `head` (in the frame the points are given in, whose
// origin is where a dataset's pose would put the sensor), 32 beams between
// -20 and +10 degrees at uneven spacing, a column every 0.2 degrees of
// azimuth, 55 microseconds apart, its lasers fired 1.7 microseconds apart
// from the top down; returns in firing order with a little range noise.
std::vector<FiredPoint> Sweep(const Vec3& head, uint32_t seed) {
  const Street street(7);
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0, 0.01);
  std::vector<double> beams;
  for (int b = 0; b < 32; ++b) beams.push_back(-20 + 30 * std::pow(b / 31.0, 1.3));
  std::vector<FiredPoint> out;
  double time = 0;
  for (int column = 0; column < 1800; ++column) {
    const double azimuth = column * 0.2 * M_PI / 180;
    for (size_t k = 0; k < beams.size(); ++k) {
      const size_t b = beams.size() - 1 - k;
      const double e = beams[b] * M_PI / 180;
      const Vec3 dir{std::cos(e) * std::cos(azimuth), std::cos(e) * std::sin(azimuth), std::sin(e)};
      const std::optional<Vec3> p = street.Hit(head, dir);
      if (!p.has_value()) continue;
      const double r = Norm(*p - head) + noise(rng);
      out.push_back({head + r * dir, time + 1.7e-6 * double(k)});
    }
    time += 55e-6;
  }
  return out;
}

TEST(SpinningLidarOrigin, FindsTheHeadAboveAndBesideThePose) {
  // A pose 0.3 m above the road, the head 1.86 m above it and 0.7 m along
  // y (as PandaSet's): the points are given relative to the pose.
  const Vec3 head{0.05, 0.7, 1.86};
  std::vector<std::vector<FiredPoint>> sweeps;
  for (uint32_t s = 0; s < 2; ++s) {
    std::vector<FiredPoint> sweep = Sweep({head.x, head.y, head.z + 0.3}, s + 1);
    for (FiredPoint& p : sweep) p.position.z -= 0.3;  // Road at z = -0.3 in the pose's frame.
    sweeps.push_back(std::move(sweep));
  }
  const LidarOriginEstimate estimate = EstimateSpinningLidarOrigin(sweeps);
  ASSERT_TRUE(estimate.reliable) << estimate.pairs << " pairs, " << estimate.concentration
                                 << " against " << estimate.concentration_at_origin;
  EXPECT_NEAR(estimate.centre.x, head.x, 0.05);
  EXPECT_NEAR(estimate.centre.y, head.y, 0.05);
  EXPECT_NEAR(estimate.centre.z, head.z, 0.03);
  EXPECT_GT(estimate.concentration, 2 * estimate.concentration_at_origin);
}

TEST(SpinningLidarOrigin, AHeadAtThePoseStaysThere) {
  const LidarOriginEstimate estimate = EstimateSpinningLidarOrigin({Sweep({0, 0, 1.8}, 3)});
  // Relative to a pose at the head itself (shift the points down).
  std::vector<FiredPoint> at_head = Sweep({0, 0, 1.8}, 3);
  for (FiredPoint& p : at_head) p.position.z -= 1.8;
  const LidarOriginEstimate same = EstimateSpinningLidarOrigin({at_head});
  EXPECT_NEAR(estimate.centre.z, 1.8, 0.03);
  EXPECT_NEAR(same.centre.x, 0, 0.05);
  EXPECT_NEAR(same.centre.y, 0, 0.05);
  EXPECT_NEAR(same.centre.z, 0, 0.03);
}

TEST(SpinningLidarOrigin, TooFewPairsIsNotReliable) {
  // No sweep, and a sweep whose returns are all fired far apart in time (no
  // column-mates): the origin is kept and the estimate says so.
  const LidarOriginEstimate none = EstimateSpinningLidarOrigin({});
  EXPECT_FALSE(none.reliable);
  EXPECT_EQ(none.pairs, 0);
  std::vector<FiredPoint> sweep = Sweep({0, 0.7, 1.9}, 4);
  for (size_t i = 0; i < sweep.size(); ++i) sweep[i].time_s = 1e-3 * double(i);
  const LidarOriginEstimate apart = EstimateSpinningLidarOrigin({sweep});
  EXPECT_FALSE(apart.reliable);
  EXPECT_EQ(apart.pairs, 0);
  EXPECT_EQ(apart.centre.z, 0);
}

}  // namespace
}  // namespace pf
