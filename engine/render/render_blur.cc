// Blurring a render (render_blur.h).
#include "engine/render/render_blur.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "absl/strings/str_cat.h"
#include "common/thread_pool.h"

namespace pf {
namespace {

Vec3 ToVec3(const std::array<float, 3>& v) { return {v[0], v[1], v[2]}; }

}  // namespace

BlurAnchor BlurAnchorOf(const Rigid& world_from_camera) {
  const Vec3& c = world_from_camera.translation;
  const Vec3 axis = Normalized(world_from_camera.rotation * Vec3{0, 0, 1});
  return {{float(c.x), float(c.y), float(c.z)}, {float(axis.x), float(axis.y), float(axis.z)}};
}

absl::Status CheckBlurAnchor(const BlurAnchor& anchor, const std::string& field) {
  double length2 = 0;
  for (int i = 0; i < 3; ++i) {
    if (!std::isfinite(anchor.centre[i]) || !std::isfinite(anchor.axis[i])) {
      return absl::InvalidArgumentError(absl::StrCat(field, ": a coordinate is not finite"));
    }
    length2 += double(anchor.axis[i]) * anchor.axis[i];
  }
  if (std::abs(std::sqrt(length2) - 1.0) > 1e-3) {
    return absl::InvalidArgumentError(
        absl::StrCat(field, ": axis of length ", std::sqrt(length2), ", not 1"));
  }
  return absl::OkStatus();
}

float RenderBlurAt(const GaussianScene& scene, const RenderCamera& camera) {
  if (!(scene.render_blur_growth > 0.f) || scene.blur_anchors.empty()) return scene.render_blur;
  const Vec3& c = camera.world_from_camera.translation;
  const Vec3 axis = camera.world_from_camera.rotation * Vec3{0, 0, 1};
  double nearest = std::numeric_limits<double>::infinity();
  for (const BlurAnchor& a : scene.blur_anchors) {
    const double angle = std::acos(std::clamp(Dot(axis, ToVec3(a.axis)), -1.0, 1.0));
    nearest = std::min(nearest, Norm(c - ToVec3(a.centre)) + kBlurAnchorMetresPerRadian * angle);
  }
  const double focal = std::sqrt(camera.model.fx() * camera.model.fy());
  const double grown =
      std::min<double>(kMaxGrownRenderBlur, focal * 1e-3 * scene.render_blur_growth * nearest);
  return std::max(scene.render_blur, static_cast<float>(grown));
}

void BlurImage(float sigma, int width, int height, int channels, std::vector<float>* image) {
  if (!(sigma > 0.f) || width <= 0 || height <= 0 || channels <= 0) return;
  const int radius = std::max(1, static_cast<int>(std::ceil(3.f * sigma)));
  std::vector<float> kernel(2 * radius + 1);
  for (int k = -radius; k <= radius; ++k) {
    kernel[k + radius] = std::exp(-0.5f * float(k * k) / (sigma * sigma));
  }
  std::vector<float>& px = *image;
  std::vector<float> pass(px.size());
  // out[i] = sum_k w_k in[i + k] / sum_k w_k over the k that stay inside.
  auto blur_line = [&](const float* in, float* out, int length, size_t step) {
    for (int i = 0; i < length; ++i) {
      const int k0 = std::max(-radius, -i), k1 = std::min(radius, length - 1 - i);
      float weight = 0.f;
      for (int k = k0; k <= k1; ++k) weight += kernel[k + radius];
      for (int c = 0; c < channels; ++c) {
        float sum = 0.f;
        for (int k = k0; k <= k1; ++k) sum += kernel[k + radius] * in[(i + k) * step + c];
        out[i * step + c] = sum / weight;
      }
    }
  };
  const size_t row = size_t(width) * channels;
  DefaultThreadPool().ParallelFor(0, height, 16, [&](int64_t y0, int64_t y1) {
    for (int64_t y = y0; y < y1; ++y) {
      blur_line(&px[y * row], &pass[y * row], width, size_t(channels));
    }
  });
  // Columns: a block of columns at a time, rows in memory order.
  DefaultThreadPool().ParallelFor(0, width, 32, [&](int64_t x0, int64_t x1) {
    std::vector<float> column(size_t(height) * channels), blurred(column.size());
    for (int64_t x = x0; x < x1; ++x) {
      for (int y = 0; y < height; ++y) {
        for (int c = 0; c < channels; ++c)
          column[size_t(y) * channels + c] = pass[y * row + x * channels + c];
      }
      blur_line(column.data(), blurred.data(), height, size_t(channels));
      for (int y = 0; y < height; ++y) {
        for (int c = 0; c < channels; ++c)
          px[y * row + x * channels + c] = blurred[size_t(y) * channels + c];
      }
    }
  });
}

void BlurRender(float sigma, RenderBuffers* buffers) {
  if (!(sigma > 0.f)) return;
  const int w = buffers->width, h = buffers->height;
  if (!buffers->rgb.empty()) BlurImage(sigma, w, h, 3, &buffers->rgb);
  if (!buffers->features.empty()) BlurImage(sigma, w, h, buffers->channels, &buffers->features);
  if (!buffers->alpha.empty()) BlurImage(sigma, w, h, 1, &buffers->alpha);
}

void BlurRender(float sigma, float actor_sigma, RenderBuffers* buffers) {
  const int w = buffers->width, h = buffers->height;
  const std::vector<uint32_t>& instance = buffers->instance;
  if (!(actor_sigma < sigma) || instance.empty() ||
      std::none_of(instance.begin(), instance.end(), [](uint32_t o) { return o != 0; })) {
    BlurRender(sigma, buffers);
    return;
  }
  // share: 1 on the actors, 0 elsewhere, blurred by sigma.
  std::vector<float> share(instance.size());
  for (size_t i = 0; i < instance.size(); ++i) share[i] = instance[i] != 0 ? 1.f : 0.f;
  BlurImage(sigma, w, h, 1, &share);
  auto mix = [&](int channels, std::vector<float>* image) {
    if (image->empty()) return;
    std::vector<float> actors = *image;
    BlurImage(actor_sigma, w, h, channels, &actors);
    BlurImage(sigma, w, h, channels, image);
    std::vector<float>& out = *image;
    for (size_t i = 0; i < share.size(); ++i) {
      for (int c = 0; c < channels; ++c) {
        const size_t k = i * channels + c;
        out[k] += share[i] * (actors[k] - out[k]);
      }
    }
  };
  mix(3, &buffers->rgb);
  mix(buffers->channels, &buffers->features);
  mix(1, &buffers->alpha);
}

}  // namespace pf
