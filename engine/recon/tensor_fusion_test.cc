// Tests of fusion as LibTorch tensor work: the hand-computed weights of
// fusion_test.cc, and equality with the C++ kernel (FuseQueries) on a
// random scene with every camera model, masks, far pixels, instances and
// every weighting, in batches smaller than the query count.
#include "engine/recon/tensor_fusion.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>

#include "engine/recon/compute_device.h"
#include "engine/recon/fusion_test_util.h"

namespace pf {
namespace {

constexpr int kW = 64, kH = 48;

struct TestView {
  ContextView view;
  ViewDepth depth;
  std::vector<uint8_t> mask;
  FusionView fusion() const { return {&view, &depth, &mask}; }
};

Rigid YawAt(double yaw, const Vec3& position) {
  Rigid pose;
  pose.rotation.m = {
      {{std::cos(yaw), 0, std::sin(yaw)}, {0, 1, 0}, {-std::sin(yaw), 0, std::cos(yaw)}}};
  pose.translation = position;
  return pose;
}

// Five views along x looking at a slanted wall about 10 m ahead, with an
// OpenCV, an f-theta and a fisheye camera among them, 8 % far pixels, a masked
// rectangle per view, the ego body on the bottom rows of views 1 and 3, and
// a colour gradient; views 100 ms apart.
std::vector<TestView> RandomViews(std::mt19937& random) {
  std::uniform_real_distribution<float> unit(0.f, 1.f);
  std::vector<TestView> views(5);
  for (int v = 0; v < 5; ++v) {
    TestView& t = views[v];
    t.view.camera = CameraModel(kW, kH, 40, 40, kW / 2.0, kH / 2.0);
    if (v == 3) t.view.camera.SetOpenCv(-0.12, 0.02, 0.001, -0.002, 0.001);
    if (v == 4) t.view.camera.SetFisheye(0.05, -0.01, 0.002, -0.0005);
    if (v == 2) t.view.camera.SetFTheta({0, 40, 0, -2, 0, 0});
    t.view.world_from_camera = YawAt(0.04 * (v - 2), {0.6 * (v - 2), 0.05 * v, 0});
    t.view.timestamp_us = 100000 * v;
    t.view.rgb = ImageF(kW, kH, 3);
    t.depth.width = kW;
    t.depth.height = kH;
    t.depth.depth.resize(kW * kH);
    t.depth.source.assign(kW * kH, uint8_t(DepthSource::kDepthMap));
    t.mask.assign(kW * kH, 0);
    if (v == 1 || v == 3) {
      t.view.ego.assign(kW * kH, 0);
      std::fill(t.view.ego.begin() + (kH - 10) * kW, t.view.ego.end(), 1);
    }
    const int mx = static_cast<int>(unit(random) * (kW - 12)),
              my = static_cast<int>(unit(random) * (kH - 10));
    for (int y = 0; y < kH; ++y) {
      for (int x = 0; x < kW; ++x) {
        const size_t j = static_cast<size_t>(y) * kW + x;
        for (int c = 0; c < 3; ++c) {
          t.view.rgb.at(x, y, c) = 0.5f + 0.4f * std::sin(0.2f * x + 0.3f * y + 2.f * c + v);
        }
        // The wall, seen with a little noise, and sometimes something in front.
        t.depth.depth[j] =
            10.f + 0.05f * x + 0.2f * unit(random) - (unit(random) < 0.05f ? 4.f : 0.f);
        if (unit(random) < 0.08f) {
          t.depth.source[j] = uint8_t(DepthSource::kFar);
          t.depth.depth[j] = 500.f;
        }
        if (x >= mx && x < mx + 12 && y >= my && y < my + 10) t.mask[j] = 1;
      }
    }
  }
  return views;
}

using ::pf::testing::RandomQueries;
using ::pf::testing::SlidingTrack;

void ExpectSameFusion(const FusedQueries& expected, const FusedQueries& actual,
                      const std::string& label) {
  ASSERT_EQ(expected.observations.size(), actual.observations.size()) << label;
  int differing = 0;
  for (size_t i = 0; i < expected.observations.size(); ++i) {
    if (!testing::SameFusedQuery(expected, actual, i) && ++differing <= 5) {
      ADD_FAILURE() << label << " query " << i << ": observations " << expected.observations[i]
                    << " vs " << actual.observations[i] << ", agreement " << expected.agreement[i]
                    << " vs " << actual.agreement[i] << ", lifespan " << expected.lifespans[i]
                    << " vs " << actual.lifespans[i] << ", red " << expected.rgb[3 * i] << " vs "
                    << actual.rgb[3 * i];
    }
  }
  EXPECT_EQ(differing, 0) << label;
}

// The tensor kernel's copy of the camera models gives CameraModel's pixels
// and CameraModel's refusals, for every lens: points in front across the
// whole field of view and past its edge, on the axis, and behind.
TEST(TensorFusion, ProjectionIsCameraModelsForEveryLens) {
  std::vector<CameraModel> cameras(4, CameraModel(640, 480, 500, 510, 321.5, 238.25));
  cameras[1].SetOpenCv(-0.28, 0.09, 0.0012, -0.0007, -0.011);
  cameras[2].SetFisheye(0.05, -0.01, 0.002, -0.0005);
  cameras[3].SetFTheta({0, 500, 0, -25, 0, 1.5});
  std::vector<double> x, y, z;
  for (double depth : {-2.0, 0.0, 1e-9, 0.5, 7.0}) {
    for (int i = -12; i <= 12; ++i) {
      for (int j = -9; j <= 9; ++j) {
        x.push_back(0.17 * i * std::abs(depth) + (i == 0 && j == 0 ? 0 : 1e-3));
        y.push_back(0.19 * j * std::abs(depth));
        z.push_back(depth);
      }
    }
  }
  for (const CameraModel& camera : cameras) {
    const TensorProjection tensor = ProjectWithTensors(camera, x, y, z);
    ASSERT_EQ(tensor.u.size(), x.size());
    int accepted = 0, refused = 0;
    for (size_t i = 0; i < x.size(); ++i) {
      double u = 0, v = 0;
      const bool valid = camera.Project({x[i], y[i], z[i]}, &u, &v);
      ASSERT_EQ(tensor.valid[i], valid) << int(camera.kind()) << " point " << i;
      if (!valid) {
        ++refused;
        continue;
      }
      ++accepted;
      EXPECT_NEAR(tensor.u[i], u, 1e-9 * (1 + std::abs(u))) << int(camera.kind()) << " " << i;
      EXPECT_NEAR(tensor.v[i], v, 1e-9 * (1 + std::abs(v))) << int(camera.kind()) << " " << i;
    }
    EXPECT_GT(accepted, 300) << int(camera.kind());
    EXPECT_GT(refused, 500) << int(camera.kind());
  }
}

TEST(TensorFusion, MatchesTheCxxKernelOnARandomSceneForEveryWeighting) {
  std::mt19937 random(7);
  const std::vector<TestView> views = RandomViews(random);
  std::vector<FusionView> fusion_views;
  for (const TestView& view : views) fusion_views.push_back(view.fusion());
  const QuerySet queries = RandomQueries(views, 900, random);
  const std::vector<InstanceTrack> tracks = SlidingTrack();
  ASSERT_GT(queries.size(), 4000u);

  for (FusionWeights weights :
       {FusionWeights::kDepthSoftmax, FusionWeights::kPlainAverage, FusionWeights::kNoDepth}) {
    for (bool lifespan : {true, false}) {
      for (bool resolution : {true, false}) {
        FusionOptions options;
        options.weights = weights;
        options.lifespan = lifespan;
        options.resolution_weighting = resolution;
        const std::string label = std::string("weights ") + std::to_string(int(weights)) +
                                  (lifespan ? " lifespan" : "") + (resolution ? " resolution" : "");
        const FusedQueries expected = FuseQueries(queries, fusion_views, tracks, options);
        absl::StatusOr<FusedQueries> actual =
            FuseQueriesOnDevice(queries, fusion_views, tracks, options, ComputeDevice{},
                                /*batch=*/1000);
        ASSERT_TRUE(actual.ok()) << actual.status();
        ExpectSameFusion(expected, *actual, label);

        if (weights == FusionWeights::kDepthSoftmax && lifespan && resolution) {
          // The scene exercises every rule: multi-view observations,
          // contradictions and finite lifespans, queries nobody else sees.
          int multi = 0, contradicted = 0, fading = 0, alone = 0;
          for (size_t i = 0; i < queries.size(); ++i) {
            multi += expected.observations[i] >= 3;
            contradicted += expected.agreement[i] < 1;
            fading += std::isfinite(expected.lifespans[i]);
            alone += expected.observations[i] == 1;
          }
          EXPECT_GT(multi, 1000) << label;
          EXPECT_GT(contradicted, 100) << label;
          EXPECT_GT(fading, 50) << label;
          EXPECT_GT(alone, 100) << label;

          // The ego rows of views 1 and 3 hide what they would observe.
          std::vector<FusionView> without_ego = fusion_views;
          std::vector<ContextView> plain = {views[1].view, views[3].view};
          for (ContextView& view : plain) view.ego.clear();
          without_ego[1].view = &plain[0];
          without_ego[3].view = &plain[1];
          const FusedQueries unmasked = FuseQueries(queries, without_ego, tracks, options);
          int fewer = 0;
          for (size_t i = 0; i < queries.size(); ++i) {
            EXPECT_LE(expected.observations[i], unmasked.observations[i]);
            fewer += expected.observations[i] < unmasked.observations[i];
          }
          EXPECT_GT(fewer, 200) << label;
        }
      }
    }
  }
}

// A 16 x 12 view from the origin along +z (fx = fy = 10, centre (8, 6)) of
// one colour at one depth.
TestView FlatView(float depth, const float (&colour)[3]) {
  TestView t;
  t.view.camera = CameraModel(16, 12, 10, 10, 8, 6);
  t.view.rgb = ImageF(16, 12, 3);
  for (int y = 0; y < 12; ++y)
    for (int x = 0; x < 16; ++x)
      for (int c = 0; c < 3; ++c) t.view.rgb.at(x, y, c) = colour[c];
  t.depth = {16, 12, std::vector<float>(16 * 12, depth), std::vector<uint8_t>(16 * 12, 0)};
  return t;
}

TEST(TensorFusion, WeightsPreferTheConsistentViewAsComputedByHand) {
  // One query at (0, 0, 10), seen by four views from the origin: the source,
  // two within the tolerance (d = 0.005 and 0.025) and one occluded.
  const float depths[4] = {10.f, 10.05f, 10.25f, 5.f};
  const float colours[4][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 1}};
  std::vector<TestView> views;
  std::vector<FusionView> fusion_views;
  for (int v = 0; v < 4; ++v) views.push_back(FlatView(depths[v], colours[v]));
  for (const TestView& view : views) fusion_views.push_back(view.fusion());
  const QuerySet q = testing::OneQueryTenMetresAhead();
  absl::StatusOr<FusedQueries> f =
      FuseQueriesOnDevice(q, fusion_views, {}, FusionOptions{}, ComputeDevice{});
  ASSERT_TRUE(f.ok()) << f.status();
  const double w1 = std::exp(-0.005 / 0.01), w2 = std::exp(-0.025 / 0.01);
  const double sum = 1 + w1 + w2;
  EXPECT_NEAR(f->rgb[0], 1 / sum, 1e-5);
  EXPECT_NEAR(f->rgb[1], w1 / sum, 1e-5);
  EXPECT_NEAR(f->rgb[2], w2 / sum, 1e-5);
  EXPECT_EQ(f->observations[0], 3);
  EXPECT_FLOAT_EQ(f->agreement[0], 1.f);
  EXPECT_TRUE(std::isinf(f->lifespans[0]));
}

// As Fusion.TheEgoBodyGivesNoColourToABilinearSample: column 7 of the second
// view is the (magenta) ego body; the bilinear sample at (8.0, 6.0) gives
// the green of column 8.
TEST(TensorFusion, TheEgoBodyGivesNoColourToABilinearSample) {
  std::vector<TestView> views = {FlatView(10.f, {1, 0, 0}), FlatView(10.f, {0, 1, 0})};
  std::vector<FusionView> fusion_views;
  views[1].view.ego.assign(16 * 12, 0);
  for (int y = 0; y < 12; ++y) {
    views[1].view.ego[y * 16 + 7] = 1;
    views[1].view.rgb.at(7, y, 0) = views[1].view.rgb.at(7, y, 2) = 1;
    views[1].view.rgb.at(7, y, 1) = 0;
  }
  for (const TestView& view : views) fusion_views.push_back(view.fusion());
  FusionOptions options;
  options.weights = FusionWeights::kPlainAverage;
  absl::StatusOr<FusedQueries> f = FuseQueriesOnDevice(testing::OneQueryTenMetresAhead(),
                                                       fusion_views, {}, options, ComputeDevice{});
  ASSERT_TRUE(f.ok()) << f.status();
  EXPECT_EQ(f->observations[0], 2);
  EXPECT_NEAR(f->rgb[0], 0.5, 1e-6);
  EXPECT_NEAR(f->rgb[1], 0.5, 1e-6);
  EXPECT_NEAR(f->rgb[2], 0.0, 1e-6);
}

TEST(TensorFusion, ARefusedDeviceIsAnErrorNotACrash) {
  const ComputeDevice gpu{ComputeDevice::Kind::kCuda, 64};
  absl::StatusOr<FusedQueries> f = FuseQueriesOnDevice(QuerySet{}, {}, {}, FusionOptions{}, gpu);
  EXPECT_EQ(f.status().code(), absl::StatusCode::kFailedPrecondition) << f.status();
}

// Where a GPU exists (a GPU worker), the same fusion on it matches the CPU.
TEST(TensorFusion, CudaMatchesTheCpu) {
  const ComputeDevice gpu{ComputeDevice::Kind::kCuda, 0};
  if (!CheckComputeDevice(gpu, "--device").ok()) {
    GTEST_SKIP() << "no CUDA GPU in this LibTorch: " << TensorBackendDescription();
  }
  std::mt19937 random(11);
  const std::vector<TestView> views = RandomViews(random);
  std::vector<FusionView> fusion_views;
  for (const TestView& view : views) fusion_views.push_back(view.fusion());
  const QuerySet queries = RandomQueries(views, 900, random);
  const std::vector<InstanceTrack> tracks = SlidingTrack();
  absl::StatusOr<FusedQueries> cpu =
      FuseQueriesOnDevice(queries, fusion_views, tracks, FusionOptions{}, ComputeDevice{});
  absl::StatusOr<FusedQueries> cuda =
      FuseQueriesOnDevice(queries, fusion_views, tracks, FusionOptions{}, gpu);
  ASSERT_TRUE(cpu.ok()) << cpu.status();
  ASSERT_TRUE(cuda.ok()) << cuda.status();
  ExpectSameFusion(*cpu, *cuda, "cuda");
}

}  // namespace
}  // namespace pf
