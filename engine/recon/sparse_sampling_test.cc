// Tests of sparse sampling: coverage without duplicates, skipping what
// earlier views covered, instance budgets.
#include "engine/recon/sparse_sampling.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <limits>
#include <set>
#include <utility>
#include <vector>

#include "engine/recon/scene_graph.h"

namespace pf {
namespace {

// A view of the plane z = 10 facing the camera, with its depth and lift.
struct PlaneView {
  ContextView view;
  ViewDepth depth;
  LiftedView lifted;
  std::vector<uint32_t> owners;

  PlaneView(int w, int h, const Rigid& pose, int64_t t = 0) {
    view.camera = CameraModel(w, h, w, w, 0.5 * w, 0.5 * h);
    view.world_from_camera = pose;
    view.timestamp_us = t;
    view.rgb = ImageF(w, h, 3);
    depth.width = w;
    depth.height = h;
    depth.depth.assign(size_t(w) * h, 10.f);
    depth.source.assign(size_t(w) * h, 0);
    lifted = LiftView(view, depth);
    owners.assign(size_t(w) * h, 0);
  }
  SamplingView sampling() const { return {&view, &depth, &lifted, &owners}; }
};

TEST(SparseSampling, ScaledBudgetFollowsPixelCount) {
  EXPECT_EQ(ScaledBudget(100000, 768, 576), 100000);
  EXPECT_EQ(ScaledBudget(100000, 384, 288), 25000);
  EXPECT_EQ(ScaledBudget(10, 1, 1), 1);
}

TEST(SparseSampling, TheStaticBudgetGrowsWithTheImagesSideAbove768x576) {
  EXPECT_EQ(ScaledStaticBudget(100000, 768, 576), 100000);
  EXPECT_EQ(ScaledStaticBudget(100000, 384, 288), 25000);     // Below: with the area.
  EXPECT_EQ(ScaledStaticBudget(100000, 1536, 1152), 200000);  // 4x the pixels, 2x the side.
  EXPECT_EQ(ScaledStaticBudget(100000, 1936, 1216), 230689);  // DGP: sqrt(5.32).
  EXPECT_EQ(ScaledBudget(100000, 1936, 1216), 532176);
}

TEST(SparseSampling, StaticSamplesCoverEveryCellWithoutDuplicates) {
  const PlaneView plane(192, 144, Rigid{});
  SamplingOptions options;
  options.static_per_view = 1728;  // Stride sqrt(192 * 144 / 1728) = 4 px.
  const QuerySet q = SampleQueries({plane.sampling()}, {}, options);
  EXPECT_EQ(q.size(), 1728u);  // One per cell on a fully valid view.
  std::set<int> pixels(q.pixels.begin(), q.pixels.end());
  EXPECT_EQ(pixels.size(), q.size());  // No pixel twice.
  // Every 8 x 8 block of the image holds samples (4 cells of 4 x 4).
  std::vector<int> per_block((192 / 8) * (144 / 8), 0);
  for (int p : q.pixels) ++per_block[(p / 192 / 8) * (192 / 8) + (p % 192) / 8];
  for (int count : per_block) EXPECT_EQ(count, 4);
  // Not the first N pixels, nor a regular grid: jittered inside the cells.
  std::set<int> x_in_cell;
  for (int p : q.pixels) x_in_cell.insert((p % 192) % 4);
  EXPECT_EQ(x_in_cell.size(), 4u);
  // Footprint = depth / f * stride = 10 / 192 * 4.
  EXPECT_NEAR(q.footprints[0], 10.0 / 192 * 4, 1e-6);
}

// Cells under 2 px wide: each still takes a pixel of its own, one whose
// centre lies in the cell (jittering a point in the cell and taking the pixel
// under it gave neighbouring cells one pixel, a Gaussian twice over).
TEST(SparseSampling, CellsNarrowerThanTwoPixelsTakeAPixelEachNeverTheSame) {
  const PlaneView plane(192, 144, Rigid{});
  for (const double stride : {1.3, 1.7, 1.95}) {
    SamplingOptions options;
    options.static_per_view = static_cast<int64_t>(std::llround(192 * 144 / (stride * stride)));
    options.fill_static_budget = false;
    const QuerySet q = SampleQueries({plane.sampling()}, {}, options);
    const double s = std::sqrt(192.0 * 144.0 / double(options.static_per_view));
    const int cells_x = static_cast<int>(std::ceil(192 / s));
    const int cells_y = static_cast<int>(std::ceil(144 / s));
    EXPECT_EQ(q.size(), static_cast<size_t>(cells_x) * cells_y) << stride;
    std::set<int> pixels(q.pixels.begin(), q.pixels.end());
    EXPECT_EQ(pixels.size(), q.size()) << stride;
    // Each column of cells holds pixels whose centres lie in it.
    std::vector<int> per_column(cells_x, 0);
    for (int p : q.pixels) ++per_column[static_cast<int>(((p % 192) + 0.5) / s)];
    for (int count : per_column) EXPECT_EQ(count, cells_y) << stride;
  }
}

TEST(SparseSampling, SecondViewOfTheSameSurfaceAddsLittle) {
  const PlaneView a(192, 144, Rigid{});
  const PlaneView b(192, 144, Rigid{});  // Same view again.
  SamplingOptions options;
  options.static_per_view = 1728;
  options.fill_static_budget = false;  // The rule alone (the budget is tested below).
  const QuerySet once = SampleQueries({a.sampling()}, {}, options);
  const QuerySet twice = SampleQueries({a.sampling(), b.sampling()}, {}, options);
  EXPECT_LT(twice.size(), once.size() * 5 / 4);
  options.skip_covered = false;
  EXPECT_EQ(SampleQueries({a.sampling(), b.sampling()}, {}, options).size(), 2 * once.size());
}

TEST(SparseSampling, RedundancyRemovalFreesBudgetForDetail) {
  // The same view twice, N_s = 1728 each: the second view adds little, so
  // the views are sampled again on grids refined by sqrt(kept / 3456) and
  // the total comes back to about V x N_s = 3456 (the second view again
  // adds less than a quarter, as in the test above), with cells (and
  // footprints) smaller by that factor. One view alone keeps its 1728
  // (nothing was removed).
  const PlaneView a(192, 144, Rigid{});
  const PlaneView b(192, 144, Rigid{});
  SamplingOptions options;
  options.static_per_view = 1728;
  const QuerySet once = SampleQueries({a.sampling()}, {}, options);
  EXPECT_EQ(once.size(), 1728u);
  const QuerySet twice = SampleQueries({a.sampling(), b.sampling()}, {}, options);
  EXPECT_GT(twice.size(), 3456u * 85 / 100);
  EXPECT_LT(twice.size(), 3456u * 125 / 100);
  // Cell side 4 px at 10 m and 192 px across 10 m: footprint 0.208 m before,
  // about 0.208 x sqrt(0.5) after.
  EXPECT_NEAR(once.footprints[0], 4 * 10.0 / 192, 1e-4);
  EXPECT_LT(twice.footprints[0], 0.8 * once.footprints[0]);
}

// Four views of the same plane leave the later three little (about a
// quarter of V x N_s kept): the refill refines each view's cells by at most
// sqrt(max_refill) = sqrt(2), to about twice what was kept (somewhat more:
// with finer footprints the later views add more), not to V x N_s, so many
// views of one street do not each crowd the scene with discs.
TEST(SparseSampling, TheRefillRefinesTheCellsByAtMostTheSquareRootOfTwo) {
  const PlaneView a(192, 144, Rigid{}), b(192, 144, Rigid{}), c(192, 144, Rigid{}),
      d(192, 144, Rigid{});
  const std::vector<SamplingView> views = {a.sampling(), b.sampling(), c.sampling(), d.sampling()};
  const size_t budget = 4 * 1728;
  SamplingOptions options;
  options.static_per_view = 1728;
  options.fill_static_budget = false;
  const size_t kept = SampleQueries(views, {}, options).size();
  EXPECT_LT(kept, budget * 3 / 10);
  options.fill_static_budget = true;
  const QuerySet filled = SampleQueries(views, {}, options);
  EXPECT_GT(filled.size(), kept * 2);
  EXPECT_LT(filled.size(), kept * 27 / 10);
  // Cell side 4 px at 10 m and 192 px across: footprint 0.208 m, here / sqrt(2).
  EXPECT_NEAR(filled.footprints[0], 4 * 10.0 / 192 / std::sqrt(2.0), 1e-3);
  options.max_refill = 100;  // Unbounded: back to about V x N_s.
  const size_t unbounded = SampleQueries(views, {}, options).size();
  EXPECT_GT(unbounded, budget * 85 / 100);
  EXPECT_LT(unbounded, budget * 125 / 100);
}

// A 192 x 144 view of the red plane z = 10 with a green 32 x 32 square at
// `square_depth` in front of it (columns and rows 80..111 and 56..87).
PlaneView SquareInFront(float square_depth = 5.f) {
  PlaneView v(192, 144, Rigid{});
  for (int y = 0; y < 144; ++y)
    for (int x = 0; x < 192; ++x) {
      const bool square = x >= 80 && x < 112 && y >= 56 && y < 88;
      v.depth.depth[y * 192 + x] = square ? square_depth : 10.f;
      v.view.rgb.at(x, y, square ? 1 : 0) = 1.f;
    }
  v.lifted = LiftView(v.view, v.depth);
  return v;
}

// A hidden query takes the colour of the background nearest it: the wall
// left of the square is red and right of it green, so the strip hidden
// behind the square's left half goes on red and its right half green. The
// wall's pixels around the square mix in the square's colour (antialiasing,
// blue here) and are stepped over; the deepest pixel of a window, the rule
// before, lies in a corner: here the ring's blue, for all of them.
TEST(SparseSampling, HiddenQueriesTakeTheNearestBackgroundColour) {
  PlaneView front = SquareInFront();
  for (int y = 0; y < 144; ++y)
    for (int x = 0; x < 192; ++x) {
      const bool square = x >= 80 && x < 112 && y >= 56 && y < 88;
      const bool ring = !square && x >= 79 && x < 113 && y >= 55 && y < 89;
      const bool wall = !square && !ring;
      const float rgb[3] = {wall && x < 96 ? 1.f : 0.f, wall && x >= 96 ? 1.f : 0.f,
                            wall ? 0.f : 1.f};
      for (int c = 0; c < 3; ++c) front.view.rgb.at(x, y, c) = rgb[c];
    }
  SamplingOptions options;
  options.static_per_view = 1728;
  options.behind_band_px = 64;
  options.fill_static_budget = false;
  options.hidden_colour_from_surfaces = false;  // The image's rule (the test below has 3D's).
  const QuerySet q = SampleQueries({front.sampling()}, {}, options);
  int left = 0, right = 0;
  for (size_t i = 0; i < q.size(); ++i) {
    if (!q.is_hidden(i)) continue;
    const int x = q.pixels[i] % 192;
    const float red = q.rgb[3 * i], green = q.rgb[3 * i + 1];
    EXPECT_FLOAT_EQ(q.rgb[3 * i + 2], 0.f) << x;  // Neither square nor ring.
    EXPECT_NEAR(red + green, 1.f, 1e-5) << x;     // A blend of the wall.
    if (x < 88) {
      EXPECT_GT(red, 0.75f) << x;
      ++left;
    } else if (x >= 104) {
      EXPECT_GT(green, 0.75f) << x;
      ++right;
    }
  }
  EXPECT_EQ(left, 4);
  EXPECT_EQ(right, 4);
}

// A van 5 m away hides a 5.8 m long, 1.7 m high piece of a wall 10 m away
// (columns 40..151, rows 56..87) from the first view; the wall is green but
// for a red band 0.8 m high (|y| < 0.4 m) that runs along the road (about x,
// the way the cameras travel: the second view is 100 m further on and 10 m
// further from the wall, a second later, and sees none of it). The band left
// and right of the van lies 2.9 m from the middle of the hidden strip, the
// green wall above and below 0.7-1 m: in the image, and in 3D without the
// road's direction, the nearest seen surface is green; along the road it is
// the band, which goes on behind the van. The wall's pixels next to the van
// mix in its blue (antialiasing) and are no evidence of the wall's colour.
// The scene is placed in the world as it is, and turned (the road 30 degrees
// off the world's x, the wall tilted 20 degrees), so that a search that only
// works along the world's axes fails.
TEST(SparseSampling, HiddenQueriesTakeTheColourOfTheSurfaceSeenAlongTheRoad) {
  auto about = [](const Vec3& axis, double degrees) {
    const double half = degrees * M_PI / 360;
    return Quat{std::cos(half), axis.x * std::sin(half), axis.y * std::sin(half),
                axis.z * std::sin(half)};
  };
  Rigid turned;
  turned.rotation = ToMatrix(about({0, 0, 1}, 30) * about({1, 0, 0}, 20));
  turned.translation = {3, -2, 1};
  for (const Rigid& world_from_scene : {Rigid{}, turned}) {
    SCOPED_TRACE(world_from_scene.rotation.m[0][0]);
    PlaneView front(192, 144, world_from_scene);
    auto van = [](int x, int y) { return x >= 40 && x < 152 && y >= 56 && y < 88; };
    for (int y = 0; y < 144; ++y)
      for (int x = 0; x < 192; ++x) {
        const bool ring =
            !van(x, y) && (van(x - 1, y) || van(x + 1, y) || van(x, y - 1) || van(x, y + 1));
        const bool band = std::abs((y + 0.5 - 72) / 192 * 10) < 0.4;
        front.depth.depth[y * 192 + x] = van(x, y) ? 5.f : 10.f;
        const float rgb[3] = {!van(x, y) && !ring && band ? 1.f : 0.f,
                              !van(x, y) && !ring && !band ? 1.f : 0.f,
                              van(x, y) || ring ? 1.f : 0.f};
        for (int c = 0; c < 3; ++c) front.view.rgb.at(x, y, c) = rgb[c];
      }
    front.lifted = LiftView(front.view, front.depth);
    Rigid ahead;  // Also 10 m back from the wall: the road is not quite along it.
    ahead.translation = {100, 0, -10};
    PlaneView later(192, 144, world_from_scene * ahead, 1'000'000);
    for (int y = 0; y < 144; ++y)
      for (int x = 0; x < 192; ++x) later.view.rgb.at(x, y, 1) = 1.f;

    SamplingOptions options;
    options.static_per_view = 1728;
    options.behind_band_px = 64;
    options.fill_static_budget = false;
    const Rigid scene_from_world = world_from_scene.Inverse();
    // The mean colour of the hidden queries in the middle of the strip
    // (|x| < 1.5 m, |y| < 0.25 m in the first camera's frame: in the band).
    auto middle = [&](const SamplingOptions& o) {
      const QuerySet q = SampleQueries({front.sampling(), later.sampling()}, {}, o);
      std::array<double, 3> sum{};
      int n = 0;
      for (size_t i = 0; i < q.size(); ++i) {
        if (!q.is_hidden(i)) continue;
        EXPECT_EQ(q.views[i], 0);
        const Vec3 p = scene_from_world * q.position(i);
        EXPECT_NEAR(p.z, 10.0, 1e-3);
        if (std::abs(p.x) >= 1.5 || std::abs(p.y) >= 0.25) continue;
        for (int c = 0; c < 3; ++c) sum[c] += q.rgb[3 * i + c];
        ++n;
      }
      EXPECT_GE(n, 4);
      for (double& v : sum) v /= std::max(n, 1);
      return sum;
    };
    const std::array<double, 3> along_road = middle(options);
    EXPECT_GT(along_road[0], 0.9);
    EXPECT_LT(along_road[1], 0.1);
    EXPECT_EQ(along_road[2], 0.0);  // The van's colour, on the wall beside it, is left out.

    options.hidden_road_scale = 1;  // 3D, every direction alike: the wall above and below.
    const std::array<double, 3> isotropic = middle(options);
    EXPECT_GT(isotropic[1], isotropic[0]);
    EXPECT_EQ(isotropic[2], 0.0);

    options.hidden_colour_from_surfaces = false;  // The image: the wall above and below.
    const std::array<double, 3> image = middle(options);
    EXPECT_GT(image[1], 0.9);
  }
}

// A car 2 m in front of a wall 10 m away hides it as much as one 5 m in
// front: a depth edge of 25 % (over the 10 % that makes a background) gets
// the same hidden queries as one of 100 %. (A first rule took only jumps over
// 50 % between neighbouring pixels for occlusions, and left holes behind
// such edges.)
TEST(SparseSampling, HiddenQueriesContinueTheBackgroundBehindAnEdge) {
  for (const float square_depth : {5.f, 8.f}) {
    SCOPED_TRACE(square_depth);
    const PlaneView front = SquareInFront(square_depth);
    SamplingOptions options;
    options.static_per_view = 1728;  // 4 px cells; hidden ones on every other.
    options.behind_band_px = 64;
    options.fill_static_budget = false;
    const QuerySet q = SampleQueries({front.sampling()}, {}, options);
    ASSERT_EQ(q.hidden.size(), q.size());
    int hidden = 0;
    for (size_t i = 0; i < q.size(); ++i) {
      if (!q.is_hidden(i)) continue;
      ++hidden;
      const int x = q.pixels[i] % 192, y = q.pixels[i] / 192;
      // Behind a square pixel, on the plane, red, sized on the coarser grid.
      EXPECT_TRUE(x >= 80 && x < 112 && y >= 56 && y < 88) << x << ", " << y;
      EXPECT_NEAR(q.positions[3 * i + 2], 10.0, 1e-3);
      EXPECT_NEAR(q.depths[i], 10.0, 1e-3);
      EXPECT_FLOAT_EQ(q.rgb[3 * i], 1.f);
      EXPECT_FLOAT_EQ(q.rgb[3 * i + 1], 0.f);
      EXPECT_NEAR(q.footprints[i], 10.0 / 192 * 4 * 2, 1e-4);
      EXPECT_EQ(q.far[i], 0);
    }
    // The square holds 8 x 8 cells; every other one in each direction.
    EXPECT_EQ(hidden, 16);
    // One query per visible cell as before.
    EXPECT_EQ(q.size() - hidden, 1728u);

    options.behind_band_px = 0;
    EXPECT_EQ(SampleQueries({front.sampling()}, {}, options).size(), 1728u);
  }
}

// A level camera 1.5 m above flat ground under the sky: the road recedes to
// the horizon, where the sky (far layer) begins. Nothing there occludes
// anything, so no hidden query: neither sky on the road's rays (it would sit
// deep underground) nor ground continued behind nearer ground, nor road
// behind the sky (the road at the horizon lies beyond the sky's 500 m, but
// the far layer hides nothing).
TEST(SparseSampling, RecedingGroundUnderTheSkyHidesNothing) {
  PlaneView road(192, 144, Rigid{});
  for (int y = 0; y < 144; ++y)
    for (int x = 0; x < 192; ++x) {
      const size_t i = static_cast<size_t>(y) * 192 + x;
      const double below = y + 0.5 - 72;  // Rows under the horizon (cy = 72).
      if (below > 0) {
        road.depth.depth[i] = static_cast<float>(1.5 * 192 / below);  // y = 1.5 m.
      } else {
        road.depth.depth[i] = 500.f;
        road.depth.source[i] = uint8_t(DepthSource::kFar);
      }
    }
  road.lifted = LiftView(road.view, road.depth);
  SamplingOptions options;
  options.static_per_view = 1728;
  options.behind_band_px = 64;
  options.fill_static_budget = false;
  const QuerySet q = SampleQueries({road.sampling()}, {}, options);
  int hidden = 0;
  for (size_t i = 0; i < q.size(); ++i) {
    if (!q.is_hidden(i)) continue;
    ++hidden;
    if (hidden < 5) {
      ADD_FAILURE() << "hidden query behind pixel " << q.pixels[i] % 192 << ", "
                    << q.pixels[i] / 192 << " at " << q.positions[3 * i] << ", "
                    << q.positions[3 * i + 1] << ", " << q.positions[3 * i + 2]
                    << (q.far[i] ? " (sky)" : "");
    }
  }
  EXPECT_EQ(hidden, 0);
  EXPECT_GT(q.size(), 500u);  // The road, and the sky on its coarser grid.
}

// The same level camera over the road, with the ego vehicle's body over
// rows >= 120 (a hood). The road goes on under the body, and comes into
// view past its edge when the camera moves on: the body's pixels get hidden
// queries where the level road seen above the body's edge meets their rays,
// in the road's colour. A body over a wall (which does not face up) gets
// none.
TEST(SparseSampling, TheRoadGoesOnUnderTheEgoBody) {
  constexpr int kBodyRow = 120;
  PlaneView road(192, 144, Rigid{});
  road.view.ego.assign(size_t(192) * 144, 0);
  for (int y = 0; y < 144; ++y) {
    for (int x = 0; x < 192; ++x) {
      const size_t i = static_cast<size_t>(y) * 192 + x;
      const double below = y + 0.5 - 72;
      if (below > 0) {
        road.depth.depth[i] = static_cast<float>(1.5 * 192 / below);  // y = 1.5 m.
      } else {
        road.depth.depth[i] = 500.f;
        road.depth.source[i] = uint8_t(DepthSource::kFar);
      }
      road.view.ego[i] = y >= kBodyRow;
      const std::array<float, 3> colour = y >= kBodyRow ? std::array<float, 3>{0.9f, 0.9f, 0.9f}
                                                        : std::array<float, 3>{0.2f, 0.3f, 0.4f};
      for (int c = 0; c < 3; ++c) road.view.rgb.at(x, y, c) = colour[c];
    }
  }
  road.lifted = LiftView(road.view, road.depth);
  SamplingOptions options;
  options.static_per_view = 1728;  // 4 px cells; hidden ones on every other.
  options.behind_band_px = 64;
  options.fill_static_budget = false;
  const QuerySet q = SampleQueries({road.sampling()}, {}, options);
  int hidden = 0;
  double nearest = 1e9, farthest = 0;
  for (size_t i = 0; i < q.size(); ++i) {
    if (!q.is_hidden(i)) continue;
    ++hidden;
    EXPECT_EQ(q.pixels[i] / 192, kBodyRow - 1);  // Shown as the road above the edge.
    EXPECT_NEAR(q.positions[3 * i + 1], 1.5, 1e-4);
    nearest = std::min<double>(nearest, q.depths[i]);
    farthest = std::max<double>(farthest, q.depths[i]);
    EXPECT_NEAR(q.depths[i], q.positions[3 * i + 2], 1e-4);
    EXPECT_FLOAT_EQ(q.rgb[3 * i], 0.2f);
    EXPECT_FLOAT_EQ(q.rgb[3 * i + 2], 0.4f);
    EXPECT_EQ(q.far[i], 0);
  }
  // The body holds 6 x 48 cells; every other one in each direction.
  EXPECT_EQ(hidden, 3 * 24);
  // Under rows 120..143: the road from 1.5 * 192 / 71.5 to 1.5 * 192 / 48.5 m.
  EXPECT_GT(nearest, 1.5 * 192 / 72);
  EXPECT_LT(nearest, 1.5 * 192 / 66);
  EXPECT_LT(farthest, 1.5 * 192 / 48);
  EXPECT_GT(farthest, 1.5 * 192 / 56);

  options.behind_band_px = 0;
  const QuerySet none = SampleQueries({road.sampling()}, {}, options);
  for (size_t i = 0; i < none.size(); ++i) EXPECT_FALSE(none.is_hidden(i));

  options.behind_band_px = 64;
  PlaneView wall(192, 144, Rigid{});  // The plane z = 10, facing the camera.
  wall.view.ego = road.view.ego;
  wall.lifted = LiftView(wall.view, wall.depth);
  const QuerySet on_wall = SampleQueries({wall.sampling()}, {}, options);
  for (size_t i = 0; i < on_wall.size(); ++i) EXPECT_FALSE(on_wall.is_hidden(i));
}

TEST(SparseSampling, HiddenQueriesAreDroppedWhereAnotherViewSeesOrPassesThem) {
  const PlaneView front = SquareInFront();
  SamplingOptions options;
  options.behind_band_px = 64;
  options.static_per_view = 1728;
  options.fill_static_budget = false;
  options.skip_covered = false;
  auto hidden_of_first_view = [&](const PlaneView& other) {
    const QuerySet q = SampleQueries({front.sampling(), other.sampling()}, {}, options);
    int hidden = 0;
    for (size_t i = 0; i < q.size(); ++i) hidden += q.is_hidden(i) && q.views[i] == 0;
    return hidden;
  };
  PlaneView sees(192, 144, Rigid{});  // The plane at 10 m, no square.
  EXPECT_EQ(hidden_of_first_view(sees), 0);
  PlaneView passes(192, 144, Rigid{});  // Sees 20 m deep there: free space.
  for (float& d : passes.depth.depth) d = 20.f;
  passes.lifted = LiftView(passes.view, passes.depth);
  EXPECT_EQ(hidden_of_first_view(passes), 0);
  PlaneView occluded(192, 144, Rigid{});  // Something at 3 m in front.
  for (float& d : occluded.depth.depth) d = 3.f;
  occluded.lifted = LiftView(occluded.view, occluded.depth);
  EXPECT_EQ(hidden_of_first_view(occluded), 16);
}

TEST(SparseSampling, DenseModeTakesEveryValidPixel) {
  PlaneView plane(32, 24, Rigid{});
  plane.lifted.valid[5] = 0;
  SamplingOptions options;
  options.dense = true;
  const QuerySet q = SampleQueries({plane.sampling()}, {}, options);
  EXPECT_EQ(q.size(), 32u * 24 - 1);
  EXPECT_NEAR(q.footprints[0], 10.0 / 32, 1e-6);
}

// An f-theta lens 150 degrees across: its pixels span far wider angles at
// the edge than at the centre, and a disc's footprint is the pixel's: the
// range times the widest angle the pixel spans, not depth / focal length.
TEST(SparseSampling, FootprintsFollowTheLensesPixelSize) {
  PlaneView plane(192, 144, Rigid{});
  const std::vector<double> poly = {0, 96, 0, -4.8};  // 96 theta - 4.8 theta^3 px.
  plane.view.camera.SetFTheta(poly);
  plane.lifted = LiftView(plane.view, plane.depth);
  SamplingOptions options;
  options.dense = true;
  const QuerySet q = SampleQueries({plane.sampling()}, {}, options);
  auto footprint_at = [&](int x, int y) {
    for (size_t k = 0; k < q.size(); ++k) {
      if (q.pixels[k] == y * 192 + x) return double(q.footprints[k]);
    }
    ADD_FAILURE() << "no query at " << x << ", " << y;
    return 0.0;
  };
  // The angle and the pixel's radial span (1 / the polynomial's slope) at
  // pixel (x, y); the tangential span sin(theta) / r(theta) is narrower.
  auto expected_at = [&](int x, int y) {
    Vec3 ray;
    EXPECT_TRUE(plane.view.camera.Unproject(x + 0.5, y + 0.5, &ray));
    const double theta = std::atan(std::hypot(ray.x, ray.y));
    const double slope = poly[1] + 3 * poly[3] * theta * theta;
    return 10.0 / std::cos(theta) / slope;
  };
  EXPECT_NEAR(footprint_at(96, 72), 10.0 / 96, 0.01 * 10.0 / 96);
  for (const auto& [x, y] : std::vector<std::pair<int, int>>{{191, 72}, {150, 72}, {96, 2}}) {
    const double expected = expected_at(x, y);
    EXPECT_NEAR(footprint_at(x, y), expected, 0.03 * expected) << x << ", " << y;
  }
  // At the right edge (61 degrees off the axis) 2.5x the centre's.
  EXPECT_GT(footprint_at(191, 72), 2.3 * footprint_at(96, 72));
}

// The footprint grid's last cells when the image is not a multiple of its
// spacing, and where the lens ends inside the image.
TEST(SparseSampling, FootprintsAtTheImagesAndTheLensesEdge) {
  SamplingOptions options;
  options.dense = true;
  auto footprints_of = [&](PlaneView& plane, const std::vector<double>& poly) {
    plane.view.camera.SetFTheta(poly);
    plane.lifted = LiftView(plane.view, plane.depth);
    const QuerySet q = SampleQueries({plane.sampling()}, {}, options);
    std::vector<double> by_pixel(plane.owners.size(), 0.0);
    for (size_t k = 0; k < q.size(); ++k) by_pixel[q.pixels[k]] = q.footprints[k];
    return by_pixel;
  };
  // 200 px wide: the last column lies 8 px past the last full cell.
  PlaneView wide(200, 150, Rigid{});
  const std::vector<double> lens = {0, 96, 0, -4.8};
  const std::vector<double> wide_footprints = footprints_of(wide, lens);
  Vec3 ray;
  ASSERT_TRUE(wide.view.camera.Unproject(199.5, 75.5, &ray));
  const double theta = std::atan(std::hypot(ray.x, ray.y));
  const double expected = 10.0 / std::cos(theta) / (96 - 3 * 4.8 * theta * theta);
  // Linear between nodes 16 px apart, the footprint over-estimates where it
  // grows fastest (measured 8 % here, 62 degrees off the axis), never under.
  EXPECT_GE(wide_footprints[75 * 200 + 199], 0.99 * expected);
  EXPECT_LE(wide_footprints[75 * 200 + 199], 1.1 * expected);
  // 96 theta - 16 theta^3 stops growing 90.5 px from the centre: the grid
  // nodes past it take their reached neighbours' footprints, so the pixels
  // just inside the lens's edge are no narrower than those further in.
  PlaneView edge(192, 144, Rigid{});
  const std::vector<double> edge_footprints = footprints_of(edge, {0, 96, 0, -16});
  EXPECT_EQ(edge_footprints[72 * 192 + 190], 0.0);  // Beyond the lens: no query.
  ASSERT_GT(edge_footprints[72 * 192 + 176], 0.0);
  EXPECT_GE(edge_footprints[72 * 192 + 184], 0.99 * edge_footprints[72 * 192 + 176]);
  EXPECT_GT(edge_footprints[72 * 192 + 176], 2 * edge_footprints[72 * 192 + 96]);
}

// A 32 x 24 view: a wall at 5 m on the left half, the plane at 10 m on the
// right, and the sky (far layer) in the last two columns. Discs on the near
// side of the occluding edge shrink; the far side, the middle of the near
// wall and a surface against the sky keep their footprint.
TEST(SparseSampling, DiscsOnTheNearSideOfAnOccludingEdgeAreSmaller) {
  PlaneView view(32, 24, Rigid{});
  for (int y = 0; y < 24; ++y) {
    for (int x = 0; x < 32; ++x) {
      const size_t j = static_cast<size_t>(y) * 32 + x;
      if (x < 16) view.depth.depth[j] = 5.f;
      if (x >= 30) {
        view.depth.depth[j] = 500.f;
        view.depth.source[j] = uint8_t(DepthSource::kFar);
      }
    }
  }
  view.lifted = LiftView(view.view, view.depth);
  SamplingOptions options;
  options.dense = true;
  options.behind_band_px = 0;
  options.edge_footprint_scale = 0.5;
  for (const double scale : {0.5, 1.0}) {
    SCOPED_TRACE(scale);
    options.edge_footprint_scale = scale;
    const QuerySet q = SampleQueries({view.sampling()}, {}, options);
    ASSERT_EQ(q.size(), 32u * 24);
    std::array<float, 32> footprint{};
    for (size_t i = 0; i < q.size(); ++i) {
      if (q.pixels[i] / 32 == 12) footprint[q.pixels[i] % 32] = q.footprints[i];
    }
    EXPECT_NEAR(footprint[14], 5.0 / 32, 1e-6);          // Inside the near wall.
    EXPECT_NEAR(footprint[15], 5.0 / 32 * scale, 1e-6);  // At its edge.
    EXPECT_NEAR(footprint[16], 10.0 / 32, 1e-6);         // Behind the edge.
    EXPECT_NEAR(footprint[29], 10.0 / 32, 1e-6);         // Against the sky.
  }
}

// Counts the instance queries of `q`, each expected in the canonical frame
// of the tests' car: its first box (t = 0) centred at x = -5 on the z = 10
// plane, so within the grown box's 2.16 m of x = -5 and at z = 10.
int InstanceQueriesInTheFirstBox(const QuerySet& q) {
  int dynamic = 0;
  for (size_t i = 0; i < q.size(); ++i) {
    if (q.owners[i] == 0) continue;
    ++dynamic;
    EXPECT_GE(q.positions[3 * i], -7.16f);
    EXPECT_LE(q.positions[3 * i], -2.84f);
    EXPECT_NEAR(q.positions[3 * i + 2], 10.f, 1e-4);
  }
  return dynamic;
}

TEST(SparseSampling, InstanceQueriesAreCanonicalAndWithinBudget) {
  PlaneView plane(192, 144, Rigid{}, /*t=*/1000000);
  // An instance whose box at t = 1 s is centred on the plane; its first box
  // (t = 0) is 5 m to the left.
  InstanceTrack car;
  car.boxes = {{0, {-5, 0, 10}, {4, 4, 1}, Quat{}}, {1000000, {0, 0, 10}, {4, 4, 1}, Quat{}}};
  const std::vector<InstanceTrack> tracks = {car};
  plane.owners = PixelOwners(plane.lifted, plane.depth, tracks, 1000000);
  int dynamic_pixels = 0;
  for (uint32_t o : plane.owners) dynamic_pixels += o == 1;
  // The box grown by kMembershipMargin spans x, y in [-2.15, 2.15] at z = 10:
  // 4.3 / 10 * 192 = 82.6 px square.
  EXPECT_NEAR(dynamic_pixels, 82.6 * 82.6, 180);
  SamplingOptions options;
  options.static_per_view = 1000;
  options.dynamic_per_instance = 500;
  const QuerySet q = SampleQueries({plane.sampling()}, tracks, options);
  const int dynamic = InstanceQueriesInTheFirstBox(q);
  EXPECT_LE(dynamic, 500);
  EXPECT_GE(dynamic, 450);  // The bisection lands near the budget.
  for (size_t i = 0; i < q.size(); ++i)
    if (q.owners[i] == 0) EXPECT_EQ(plane.owners[q.pixels[i]], 0u);
}

// A camera at `x` metres along world x, turned `degrees` about its optical axis.
Rigid CameraAt(double x, double degrees) {
  const double half = 0.5 * degrees * M_PI / 180.0;
  Rigid pose;
  pose.rotation = ToMatrix(Quat{std::cos(half), 0, 0, std::sin(half)});
  pose.translation = {x, 0, 0};
  return pose;
}

TEST(SparseSampling, ACameraStandsStillWhenEveryViewIsWithinFiveCentimetresAndTwoDegrees) {
  std::vector<ContextView> views(9);
  const auto set = [&](size_t v, const char* camera, double x, double degrees) {
    views[v].camera_id = camera;
    views[v].world_from_camera = CameraAt(x, degrees);
  };
  set(0, "still", 0, 0);
  set(1, "moving", 0, 0);
  set(2, "still", 0.04, 1.5);  // Within 5 cm and 2 degrees of its first.
  set(3, "moving", 0.04, 0);
  set(4, "moving", 0.08, 0);  // 8 cm from its first: it moves.
  set(5, "turning", 0, 0);
  set(6, "turning", 0, 3);  // 3 degrees: it turns.
  set(7, "alone", 0, 0);    // One view: nothing to compare.
  set(8, "still", 0.01, -1);
  const std::vector<bool> still = StillCameraViews(views);
  const std::vector<bool> want = {true, false, true, false, false, false, false, false, true};
  EXPECT_EQ(still, want);
}

TEST(SparseSampling, AViewsStaticDensityScalesItsQueries) {
  const PlaneView plane(192, 144, Rigid{});
  SamplingOptions options;
  options.static_per_view = 1728;  // Stride 4 px at density 1.
  SamplingView dense = plane.sampling();
  dense.static_density = 4;  // Cells half as wide: stride 2 px.
  const QuerySet q = SampleQueries({dense}, {}, options);
  EXPECT_EQ(q.size(), 4u * 1728u);
  std::set<int> pixels(q.pixels.begin(), q.pixels.end());
  EXPECT_EQ(pixels.size(), q.size());
  // Every 4 x 4 block holds one sample per 2 x 2 cell.
  std::vector<int> per_block((192 / 4) * (144 / 4), 0);
  for (int p : q.pixels) ++per_block[(p / 192 / 4) * (192 / 4) + (p % 192) / 4];
  for (int count : per_block) EXPECT_EQ(count, 4);
}

}  // namespace
}  // namespace pf

namespace pf {
namespace {

// A view of the plane z = 10 from 10 m behind the origin's (PlaneView's)
// camera: it sees that view's whole area (x in [-5, 5], y in [-3.75, 3.75])
// at half the resolution, and more around it.
PlaneView FarPlaneView() {
  Rigid back;
  back.translation = {0, 0, -10};
  PlaneView far_view(192, 144, back);
  for (float& d : far_view.depth.depth) d = 20.f;
  far_view.lifted = LiftView(far_view.view, far_view.depth);
  return far_view;
}

// The queries of view 0 (the far view) inside the near view's area.
int FarViewQueriesInside(const QuerySet& q) {
  int inside = 0;
  for (size_t i = 0; i < q.size(); ++i)
    if (q.views[i] == 0 && std::abs(q.positions[3 * i]) < 4.8f &&
        std::abs(q.positions[3 * i + 1]) < 3.6f)
      ++inside;
  return inside;
}

TEST(SparseSampling, SurfacesAreLeftToTheViewThatSeesThemClosest) {
  // Both look along +z at the plane z = 10.
  const PlaneView near_view(192, 144, Rigid{});
  const PlaneView far_view = FarPlaneView();
  SamplingOptions options;
  options.static_per_view = 1728;
  options.fill_static_budget = false;  // The rule alone.
  // The far view first: without the rule it would claim the shared area.
  const QuerySet q = SampleQueries({far_view.sampling(), near_view.sampling()}, {}, options);
  int far_inside = 0, far_outside = 0, near_count = 0;
  for (size_t i = 0; i < q.size(); ++i) {
    const float x = q.positions[3 * i], y = q.positions[3 * i + 1];
    if (q.views[i] == 1) {
      ++near_count;
    } else if (std::abs(x) < 4.8f && std::abs(y) < 3.6f) {
      ++far_inside;
    } else {
      ++far_outside;
    }
  }
  EXPECT_EQ(near_count, 1728);
  EXPECT_EQ(far_inside, 0);
  EXPECT_GT(far_outside, 1728 / 2);  // 3/4 of the far view is outside the near one.
  options.finer_view_ratio = 0;      // Off: the far view keeps its samples there.
  const QuerySet plain = SampleQueries({far_view.sampling(), near_view.sampling()}, {}, options);
  EXPECT_GT(FarViewQueriesInside(plain), 300);
}

// The same two views with the near one 2 s later: within finer_view_seconds
// the far view leaves the shared area to it; beyond, it keeps its own
// samples there (a scene fading with time would draw the near view's discs
// faded at the far view's time).
TEST(SparseSampling, SurfacesAreLeftToAFinerViewOnlyWithinItsTime) {
  const PlaneView near_view(192, 144, Rigid{}, /*t=*/2000000);
  const PlaneView far_view = FarPlaneView();
  auto far_inside = [&](double seconds) {
    SamplingOptions options;
    options.static_per_view = 1728;
    options.fill_static_budget = false;
    options.finer_view_seconds = seconds;
    return FarViewQueriesInside(
        SampleQueries({far_view.sampling(), near_view.sampling()}, {}, options));
  };
  EXPECT_EQ(far_inside(std::numeric_limits<double>::infinity()), 0);  // The default.
  EXPECT_EQ(far_inside(2.5), 0);
  EXPECT_GT(far_inside(1.5), 300);  // As with the rule off.
}

// A rolling-shutter view read top to bottom over 100 ms while the car
// drives 3 m to +x: each pixel is tested against the box at its line's time,
// and its query goes to the canonical frame of that time.
TEST(SparseSampling, ARollingShutterViewTakesEachLinesActors) {
  PlaneView plane(192, 144, Rigid{}, /*t=*/1000000);
  InstanceTrack car;
  car.boxes = {{0, {-5, 0, 10}, {4, 4, 1}, Quat{}},
               {1000000, {0, 0, 10}, {4, 4, 1}, Quat{}},
               {1100000, {3, 0, 10}, {4, 4, 1}, Quat{}}};
  const std::vector<InstanceTrack> tracks = {car};
  const RollingShutter shutter{RollingShutter::Readout::kTopToBottom, 100000, Rigid{}};
  // The mean column of the car's pixels in row `y`.
  auto centre_of_row = [&](const std::vector<uint32_t>& owners, int y) {
    double sum = 0, count = 0;
    for (int x = 0; x < 192; ++x) {
      if (owners[size_t(y) * 192 + x] == 1) {
        sum += x + 0.5;
        ++count;
      }
    }
    return count > 0 ? sum / count : -1.0;
  };
  const std::vector<uint32_t> global =
      PixelOwners(plane.lifted, plane.depth, tracks, 1000000, std::nullopt);
  EXPECT_NEAR(centre_of_row(global, 40), 96, 1);
  EXPECT_NEAR(centre_of_row(global, 105), 96, 1);
  plane.view.rolling_shutter = shutter;
  plane.owners = PixelOwners(plane.lifted, plane.depth, tracks, 1000000, shutter);
  // Row 40 is read 27.8 ms in (the time sample at 25 ms: the box at
  // x = 0.75 m, 14.4 px right), row 105 at 73.1 ms (75 ms: x = 2.25 m,
  // 43.2 px right).
  EXPECT_NEAR(centre_of_row(plane.owners, 40), 96 + 14.4, 1);
  EXPECT_NEAR(centre_of_row(plane.owners, 105), 96 + 43.2, 1);
  EXPECT_EQ(LineTime(1000000, shutter, LineTimeSample(shutter, 192, 144, 105 * 192 + 7)), 1075000);

  SamplingOptions options;
  options.static_per_view = 1000;
  options.dynamic_per_instance = 500;
  const QuerySet q = SampleQueries({plane.sampling()}, tracks, options);
  // Canonical = the box at t = 0, whichever line saw the point.
  EXPECT_GE(InstanceQueriesInTheFirstBox(q), 400);
}

}  // namespace
}  // namespace pf
