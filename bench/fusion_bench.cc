// pf_fusion_bench: how long spatial-temporal fusion (fusion.h) takes at the
// size of a real reconstruction, in the C++ kernel (FuseQueries, on the
// engine's thread pool) and as LibTorch tensor work (FuseQueriesOnDevice) on
// the CPU and on each --devices entry. Prints one JSON object.
//
//   pf_fusion_bench [--views 12] [--width 768] [--height 576]
//                   [--queries_per_view 100000] [--runs 3] [--devices cpu,cuda:0]
//
// The scene is made up, so it needs no clip: --views views 0.5 m apart along
// x, turning a little, looking at a slanted wall about 10 m ahead (a few
// pixels 4 m nearer, 8 % on the far layer, a masked rectangle each), and
// queries lifted from random pixels of every view (a fifth pushed off the
// surface, a tenth on the far layer, a tenth on an instance sliding 1 m).
// The default is the size of `pf synth`'s default clip (12 views 768 x 576)
// with about as many queries as its analytic reconstruction fuses.
//
// Each path is timed --runs times after one warm-up run (for a GPU: its
// context, kernels and allocator); min / median / max seconds. Each device's
// result is compared with the C++ kernel's: "differing" counts the queries
// whose observations, agreement or lifespan differ, or whose colour differs
// by 1e-5 or more (SameFusedQuery, fusion_test_util.h, as tensor_fusion_test.cc).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <random>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "common/command_line.h"
#include "common/elapsed.h"
#include "common/status_macros.h"
#include "common/thread_pool.h"
#include "engine/recon/compute_device.h"
#include "engine/recon/fusion.h"
#include "engine/recon/fusion_test_util.h"
#ifdef PF_HAVE_TORCH
#include "engine/recon/tensor_fusion.h"
#endif

namespace pf {
namespace {

struct BenchView {
  ContextView view;
  ViewDepth depth;
  std::vector<uint8_t> mask;
};

std::vector<BenchView> MakeViews(int count, int width, int height, std::mt19937& random) {
  std::uniform_real_distribution<float> unit(0.f, 1.f);
  std::vector<BenchView> views(count);
  const double focal = 0.8 * width;
  for (int v = 0; v < count; ++v) {
    BenchView& b = views[v];
    b.view.camera = CameraModel(width, height, focal, focal, width / 2.0, height / 2.0);
    const double yaw = 0.01 * (v - count / 2);
    Rigid pose;
    pose.rotation.m = {
        {{std::cos(yaw), 0, std::sin(yaw)}, {0, 1, 0}, {-std::sin(yaw), 0, std::cos(yaw)}}};
    pose.translation = {0.5 * (v - count / 2), 0.02 * v, 0};
    b.view.world_from_camera = pose;
    b.view.timestamp_us = 100000 * v;
    b.view.rgb = ImageF(width, height, 3);
    const size_t pixels = static_cast<size_t>(width) * height;
    b.depth.width = width;
    b.depth.height = height;
    b.depth.depth.resize(pixels);
    b.depth.source.assign(pixels, uint8_t(DepthSource::kDepthMap));
    b.mask.assign(pixels, 0);
    const int mw = width / 6, mh = height / 6;
    const int mx = static_cast<int>(unit(random) * (width - mw));
    const int my = static_cast<int>(unit(random) * (height - mh));
    for (int y = 0; y < height; ++y) {
      for (int x = 0; x < width; ++x) {
        const size_t j = static_cast<size_t>(y) * width + x;
        for (int c = 0; c < 3; ++c) {
          b.view.rgb.at(x, y, c) = 0.5f + 0.4f * std::sin(0.02f * x + 0.03f * y + 2.f * c + v);
        }
        b.depth.depth[j] =
            10.f + 4.f * x / width + 0.2f * unit(random) - (unit(random) < 0.05f ? 4.f : 0.f);
        if (unit(random) < 0.08f) {
          b.depth.source[j] = uint8_t(DepthSource::kFar);
          b.depth.depth[j] = 500.f;
        }
        if (x >= mx && x < mx + mw && y >= my && y < my + mh) b.mask[j] = 1;
      }
    }
  }
  return views;
}

int64_t Differing(const FusedQueries& a, const FusedQueries& b) {
  if (a.observations.size() != b.observations.size()) {
    return static_cast<int64_t>(std::max(a.observations.size(), b.observations.size()));
  }
  int64_t differing = 0;
  for (size_t i = 0; i < a.observations.size(); ++i) {
    differing += !testing::SameFusedQuery(a, b, i);
  }
  return differing;
}

struct Timing {
  std::vector<double> seconds;
  nlohmann::json Json() const {
    std::vector<double> s = seconds;
    std::sort(s.begin(), s.end());
    return {{"min", s.front()}, {"median", s[s.size() / 2]}, {"max", s.back()}};
  }
};

// Runs `fuse` once to warm up, then `runs` times; returns the timings and
// the last result.
template <typename Fuse>
absl::StatusOr<std::pair<Timing, FusedQueries>> TimeRuns(int runs, const Fuse& fuse) {
  ASSIGN_OR_RETURN(FusedQueries result, fuse());
  Timing timing;
  for (int r = 0; r < runs; ++r) {
    const auto start = std::chrono::steady_clock::now();
    ASSIGN_OR_RETURN(result, fuse());
    timing.seconds.push_back(SecondsSince(start));
  }
  return std::make_pair(std::move(timing), std::move(result));
}

absl::Status Run(const std::vector<std::string>& args) {
  ASSIGN_OR_RETURN(CommandLine cl,
                   CommandLine::Parse(
                       args, {"views", "width", "height", "queries_per_view", "runs", "devices"}));
  ASSIGN_OR_RETURN(int64_t view_count, cl.GetInt("views", 12));
  ASSIGN_OR_RETURN(int64_t width, cl.GetInt("width", 768));
  ASSIGN_OR_RETURN(int64_t height, cl.GetInt("height", 576));
  ASSIGN_OR_RETURN(int64_t per_view, cl.GetInt("queries_per_view", 100000));
  ASSIGN_OR_RETURN(int64_t runs, cl.GetInt("runs", 3));
  if (view_count < 1 || view_count > 256) {
    return absl::InvalidArgumentError(absl::StrCat("--views: 1 to 256, got ", view_count));
  }
  if (width < 16 || width > 8192 || height < 16 || height > 8192) {
    return absl::InvalidArgumentError(
        absl::StrCat("--width, --height: 16 to 8192, got ", width, " x ", height));
  }
  if (per_view < 1 || per_view > 10000000) {
    return absl::InvalidArgumentError(
        absl::StrCat("--queries_per_view: 1 to 10000000, got ", per_view));
  }
  if (runs < 1 || runs > 100) {
    return absl::InvalidArgumentError(absl::StrCat("--runs: 1 to 100, got ", runs));
  }
  std::vector<ComputeDevice> devices;
  for (const std::string& name : cl.GetList("devices")) {
    ASSIGN_OR_RETURN(ComputeDevice device, ParseComputeDevice(name, "--devices"));
    devices.push_back(device);
  }
  if (!cl.Has("devices")) devices.push_back(ComputeDevice{});

  std::mt19937 random(5);
  const std::vector<BenchView> views = MakeViews(
      static_cast<int>(view_count), static_cast<int>(width), static_cast<int>(height), random);
  std::vector<FusionView> fusion_views;
  for (const BenchView& b : views) fusion_views.push_back({&b.view, &b.depth, &b.mask});
  const QuerySet queries = testing::RandomQueries(views, static_cast<int>(per_view), random, 0.02f);
  const std::vector<InstanceTrack> tracks = testing::SlidingTrack(views.back().view.timestamp_us);
  const FusionOptions options;

  ASSIGN_OR_RETURN(auto cxx,
                   TimeRuns(static_cast<int>(runs), [&]() -> absl::StatusOr<FusedQueries> {
                     return FuseQueries(queries, fusion_views, tracks, options);
                   }));
  int64_t observed = 0;
  for (uint16_t n : cxx.second.observations) observed += n > 0;

  nlohmann::json report = {{"views", view_count},
                           {"width", width},
                           {"height", height},
                           {"queries", queries.size()},
                           {"observed", observed},
                           {"runs", runs},
                           {"pool_workers", DefaultThreadPool().num_threads()},
                           {"backend", TensorBackendDescription()},
                           {"cxx", {{"seconds", cxx.first.Json()}}}};
  nlohmann::json& tensor_json = report["tensor"] = nlohmann::json::object();
  for (const ComputeDevice& device : devices) {
    nlohmann::json& entry = tensor_json[device.ToString()];
#ifdef PF_HAVE_TORCH
    if (const absl::Status usable = CheckComputeDevice(device, "--devices"); !usable.ok()) {
      entry = {{"skipped", std::string(usable.message())}};
      continue;
    }
    ASSIGN_OR_RETURN(auto tensor,
                     TimeRuns(static_cast<int>(runs), [&]() -> absl::StatusOr<FusedQueries> {
                       return FuseQueriesOnDevice(queries, fusion_views, tracks, options, device);
                     }));
    entry = {{"seconds", tensor.first.Json()}, {"differing", Differing(cxx.second, tensor.second)}};
#else
    entry = {{"skipped", "this build has no LibTorch"}};
#endif
  }
  std::printf("%s\n", report.dump().c_str());
  return absl::OkStatus();
}

}  // namespace
}  // namespace pf

int main(int argc, char** argv) {
  return pf::ExitStatusFor("pf_fusion_bench",
                           pf::Run(std::vector<std::string>(argv + 1, argv + argc)));
}
