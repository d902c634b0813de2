// Fused queries to Gaussians: surface discs sized by their footprint.
#include "engine/recon/gaussian_decoder.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "common/thread_pool.h"

namespace pf {
namespace {

// The agreement channel of a visible query is at least this.
constexpr float kMinAgreement = 1e-6f;

// The opacity of a visible query of the given agreement and observations.
double AgreementOpacity(double agreement, int observations, const DecoderOptions& options) {
  const double contradictions =
      agreement > 0 ? std::round(observations * (1 / agreement - 1)) : 0.0;
  if (options.contradicted_views > 0 && contradictions >= options.contradicted_views) {
    const double low = options.contradicted_min_opacity;
    return low + (options.max_opacity - low) * agreement * agreement * agreement;
  }
  return options.min_opacity + (options.max_opacity - options.min_opacity) * agreement;
}

}  // namespace

std::optional<double> FadeSigma(const std::vector<std::string>& view_cameras,
                                const std::vector<int64_t>& view_times_us, double fade_frames) {
  if (!(fade_frames > 0) || view_times_us.empty()) return std::nullopt;
  std::map<std::string, std::vector<int64_t>> times_of_camera;
  for (size_t v = 0; v < view_times_us.size(); ++v)
    times_of_camera[view_cameras[v]].push_back(view_times_us[v]);
  double gaps = 0;
  int64_t count = 0;
  for (auto& [camera, times] : times_of_camera) {
    std::sort(times.begin(), times.end());
    times.erase(std::unique(times.begin(), times.end()), times.end());
    if (times.size() < 2) continue;
    gaps += double(times.back() - times.front()) * 1e-6;
    count += static_cast<int64_t>(times.size()) - 1;
  }
  if (count == 0) return std::nullopt;
  return std::max(0.0, fade_frames * gaps / double(count) - 1.0);
}

void FadeStaticGaussians(const std::vector<std::string>& view_cameras,
                         const std::vector<int64_t>& view_times_us,
                         const std::vector<uint32_t>& owners, const std::vector<uint8_t>& far,
                         double fade_frames, GaussianScene* scene) {
  const std::optional<double> fade_sigma = FadeSigma(view_cameras, view_times_us, fade_frames);
  if (!fade_sigma.has_value()) return;
  const float sigma = static_cast<float>(*fade_sigma);
  for (size_t i = 0; i < scene->size(); ++i) {
    if (owners[i] != 0 || far[i]) continue;
    scene->lifespans[i] = std::min(scene->lifespans[i], sigma);
  }
  const auto [first, last] = std::minmax_element(view_times_us.begin(), view_times_us.end());
  scene->fade_span.begin = static_cast<float>(double(*first - scene->time_origin_us) * 1e-6);
  scene->fade_span.end = static_cast<float>(double(*last - scene->time_origin_us) * 1e-6);
}

Quat DiscFrame(const Vec3& normal_in, const Vec3& ray_in, double max_stretch, double* stretch) {
  const Vec3 n = Normalized(normal_in);
  const Vec3 ray = Normalized(ray_in);
  const double cos_theta = std::abs(Dot(n, ray));
  *stretch = std::min(max_stretch, 1.0 / std::max(cos_theta, 1e-6));
  Vec3 t1 = ray - Dot(ray, n) * n;
  if (Norm(t1) < 1e-6) {
    // Seen head-on: any tangent will do.
    t1 = std::abs(n.x) < 0.9 ? Cross(n, Vec3{1, 0, 0}) : Cross(n, Vec3{0, 1, 0});
  }
  t1 = Normalized(t1);
  const Vec3 t2 = Cross(n, t1);
  return FromMatrix(Mat3::FromColumns(t1, t2, n));
}

GaussianScene DecodeGaussians(const QuerySet& queries, const FusedQueries& fused,
                              const std::vector<int64_t>& view_times_us, int64_t time_origin_us,
                              const std::vector<InstanceTrack>& tracks,
                              const DecoderOptions& options) {
  GaussianScene scene;
  scene.num_channels = kReconChannels;
  scene.sh_degree = -1;
  scene.time_origin_us = time_origin_us;
  scene.low_pass = options.low_pass.value_or(kExactDepthLowPass);
  scene.order_band = options.order_band;
  scene.instances = tracks;
  const size_t n = queries.size();
  scene.Resize(n);
  DefaultThreadPool().ParallelFor(0, static_cast<int64_t>(n), 4096, [&](int64_t b, int64_t e) {
    for (int64_t i = b; i < e; ++i) {
      for (int c = 0; c < 3; ++c) scene.means[3 * i + c] = queries.positions[3 * i + c];
      double stretch = 1;
      const Quat q = DiscFrame(queries.normal(i), queries.ray(i), options.max_stretch, &stretch);
      scene.rotations[4 * i] = float(q.w);
      scene.rotations[4 * i + 1] = float(q.x);
      scene.rotations[4 * i + 2] = float(q.y);
      scene.rotations[4 * i + 3] = float(q.z);
      const double f = std::max(1e-6, double(queries.footprints[i]));
      scene.log_scales[3 * i] = float(std::log(options.tangent_sigma * f * stretch));
      scene.log_scales[3 * i + 1] = float(std::log(options.tangent_sigma * f));
      scene.log_scales[3 * i + 2] = float(std::log(options.normal_sigma * f));
      const bool hidden = queries.is_hidden(i);
      const double a = std::clamp(double(fused.agreement[i]), 0.0, 1.0);
      const double opacity =
          hidden ? options.max_opacity : AgreementOpacity(a, fused.observations[i], options);
      scene.opacity_logits[i] = LogitOfOpacity(opacity);
      float* feat = &scene.features[static_cast<size_t>(i) * kReconChannels];
      // A hidden query has no observation of its own (its source view sees
      // the foreground there): it keeps the background colour it was given.
      const float* rgb = hidden ? &queries.rgb[3 * i] : &fused.rgb[3 * i];
      for (int c = 0; c < 3; ++c) feat[c] = std::clamp(rgb[c], 0.f, 1.f);
      for (int c = 0; c < 3; ++c) feat[3 + c] = queries.normals[3 * i + c];
      // 0 marks hidden queries only.
      feat[kAgreementChannel] = hidden ? 0.f : std::max(float(a), kMinAgreement);
      scene.times[i] = float((view_times_us[queries.views[i]] - time_origin_us) * 1e-6);
      scene.lifespans[i] = fused.lifespans[i];
      scene.owners[i] = queries.owners[i];
    }
  });
  return scene;
}

}  // namespace pf
