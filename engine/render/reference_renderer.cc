// The reference renderer: per pixel, every Gaussian, in depth order.
#include "engine/render/reference_renderer.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "engine/render/instance_pose.h"
#include "engine/render/raster_sh.h"
#include "engine/render/splat_projection.h"

namespace pf::testing {
namespace {

// A Gaussian as seen by the camera.
struct Splat {
  bool visible = false;
  double u = 0, v = 0;          // Projected centre, pixels.
  double conic[3] = {0, 0, 0};  // Inverse 2D covariance: xx, xy, yy.
  double opacity = 0;
  double depth = 0;
  float rgb[3] = {0, 0, 0};
  uint32_t owner = 0;
  double axes[2][2] = {{0, 0}, {0, 0}};  // Screen images of the first two scaled axes (columns).
};

// 2x3 times 3x3.
void Mul23(const double a[2][3], const Mat3& b, double out[2][3]) {
  for (int r = 0; r < 2; ++r)
    for (int c = 0; c < 3; ++c)
      out[r][c] = a[r][0] * b.m[0][c] + a[r][1] * b.m[1][c] + a[r][2] * b.m[2][c];
}

}  // namespace

RenderBuffers ReferenceRender(const GaussianScene& scene, const RenderCamera& camera,
                              int64_t timestamp_us, const std::vector<ActorEdit>& edits,
                              const RenderOptions& options, std::vector<uint8_t>* ambiguous) {
  const CameraModel& model = camera.model;
  const int width = model.width(), height = model.height();
  const size_t n = scene.size();
  const int nc = scene.num_channels;
  // The fade's time, held within the scene's fade span.
  const double t_fade = std::clamp(static_cast<double>(timestamp_us - scene.time_origin_us) * 1e-6,
                                   double{scene.fade_span.begin}, double{scene.fade_span.end});

  // World-from-owner poses and which owners are drawn.
  std::vector<Rigid> world_from_owner(scene.instances.size() + 1);
  std::vector<bool> drawn(scene.instances.size() + 1, true);
  for (size_t k = 0; k < scene.instances.size(); ++k) {
    world_from_owner[k + 1] = InstancePoseAt(scene.instances[k].boxes, timestamp_us);
    for (const ActorEdit& edit : edits) {
      if (edit.instance_id != scene.instances[k].id) continue;
      if (edit.kind == ActorEdit::Kind::kRemove) {
        drawn[k + 1] = false;
      } else {
        world_from_owner[k + 1] = BoxPose(InterpolateBox(edit.boxes, timestamp_us)) *
                                  BoxPose(scene.instances[k].boxes.front()).Inverse();
      }
    }
  }
  const Rigid camera_from_world = camera.world_from_camera.Inverse();

  // Project every Gaussian.
  std::vector<Splat> splats(n);
  for (size_t i = 0; i < n; ++i) {
    Splat& s = splats[i];
    s.owner = scene.owners[i];
    if (!drawn[s.owner]) continue;
    const Rigid camera_from_owner = camera_from_world * world_from_owner[s.owner];
    const Vec3 mean{scene.means[3 * i], scene.means[3 * i + 1], scene.means[3 * i + 2]};
    const Vec3 p = camera_from_owner * mean;
    if (p.z < options.near_plane) continue;
    if (!model.Project(p, &s.u, &s.v)) continue;
    s.depth = p.z;
    s.opacity = OpacityOfLogit(scene.opacity_logits[i]);
    if (!std::isinf(scene.lifespans[i])) {
      const double x = (t_fade - scene.times[i]) / (scene.lifespans[i] + 1.0);
      s.opacity *= std::exp(-0.5 * x * x);
    }
    // Covariance in the camera frame: M M^T with M = R_co * R_q * S.
    const Quat q{scene.rotations[4 * i], scene.rotations[4 * i + 1], scene.rotations[4 * i + 2],
                 scene.rotations[4 * i + 3]};
    Mat3 scale;
    for (int a = 0; a < 3; ++a) scale.m[a][a] = std::exp(scene.log_scales[3 * i + a]);
    const Mat3 m = camera_from_owner.rotation * ToMatrix(q) * scale;
    // Jacobian of the pixel w.r.t. the camera point: distortion Jacobian at
    // the (clamped) normalised point times the perspective Jacobian.
    // Clamp: 15% of the image beyond its borders (pinhole), the valid
    // radius (distorted models).
    const double r = std::min(model.max_normalized_radius(), 1e3);
    const bool pinhole = !model.has_distortion();
    const double x_lo = pinhole ? (-0.15 * width - model.cx()) / model.fx() : -r;
    const double x_hi = pinhole ? (1.15 * width - model.cx()) / model.fx() : r;
    const double y_lo = pinhole ? (-0.15 * height - model.cy()) / model.fy() : -r;
    const double y_hi = pinhole ? (1.15 * height - model.cy()) / model.fy() : r;
    const double tx = std::clamp(p.x / p.z, x_lo, x_hi);
    const double ty = std::clamp(p.y / p.z, y_lo, y_hi);
    double d[2][2] = {{model.fx(), 0}, {0, model.fy()}};
    if (model.has_distortion()) {
      const double h = 1e-6;
      double xp, yp, xm, ym;
      model.Distort(tx + h, ty, &xp, &yp);
      model.Distort(tx - h, ty, &xm, &ym);
      d[0][0] = model.fx() * (xp - xm) / (2 * h);
      d[1][0] = model.fy() * (yp - ym) / (2 * h);
      model.Distort(tx, ty + h, &xp, &yp);
      model.Distort(tx, ty - h, &xm, &ym);
      d[0][1] = model.fx() * (xp - xm) / (2 * h);
      d[1][1] = model.fy() * (yp - ym) / (2 * h);
    }
    const double persp[2][3] = {{1 / p.z, 0, -tx / p.z}, {0, 1 / p.z, -ty / p.z}};
    double jac[2][3];
    for (int r = 0; r < 2; ++r)
      for (int c = 0; c < 3; ++c) jac[r][c] = d[r][0] * persp[0][c] + d[r][1] * persp[1][c];
    double b[2][3];
    Mul23(jac, m, b);
    const double low_pass = scene.low_pass;
    const double cxx = b[0][0] * b[0][0] + b[0][1] * b[0][1] + b[0][2] * b[0][2] + low_pass;
    const double cxy = b[0][0] * b[1][0] + b[0][1] * b[1][1] + b[0][2] * b[1][2];
    const double cyy = b[1][0] * b[1][0] + b[1][1] * b[1][1] + b[1][2] * b[1][2] + low_pass;
    for (int r = 0; r < 2; ++r)
      for (int c = 0; c < 2; ++c) s.axes[r][c] = b[r][c];
    const double det = cxx * cyy - cxy * cxy;
    if (det <= 0) continue;
    s.conic[0] = cyy / det;
    s.conic[1] = -cxy / det;
    s.conic[2] = cxx / det;
    if (scene.sh_degree >= 0) {
      const Vec3 eye = world_from_owner[s.owner].Inverse() * camera.world_from_camera.translation;
      const Vec3 dir = Normalized(mean - eye);
      raster::EvalShColor(&scene.sh[i * 3 * scene.sh_coeffs()], scene.sh_degree,
                          static_cast<float>(dir.x), static_cast<float>(dir.y),
                          static_cast<float>(dir.z), s.rgb);
    }
    s.visible = true;
  }

  // Depth order (within the scene's order band, the band's fixed order),
  // ties by index.
  std::vector<size_t> order(n);
  std::iota(order.begin(), order.end(), 0);
  auto key = [&](size_t i) {
    return raster::SortDepthBits(static_cast<float>(splats[i].depth), static_cast<uint32_t>(i),
                                 scene.order_band);
  };
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return key(a) < key(b); });

  RenderBuffers out;
  out.width = width;
  out.height = height;
  out.channels = nc;
  const size_t pixels = static_cast<size_t>(width) * height;
  out.rgb.assign(pixels * 3, 0.f);
  out.alpha.assign(pixels, 0.f);
  if (options.features) out.features.assign(pixels * nc, 0.f);
  if (options.depth) out.depth.assign(pixels, 0.f);
  if (options.instance) out.instance.assign(pixels, 0);

  if (ambiguous != nullptr) ambiguous->assign(static_cast<size_t>(width) * height, 0);
  std::vector<double> features(nc);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const double u = x + 0.5, v = y + 0.5;
      double transmittance = 1, depth = 0, best = 0, rgb[3] = {0, 0, 0};
      uint32_t best_owner = 0;
      bool close_call = false;
      std::fill(features.begin(), features.end(), 0.0);
      for (size_t i : order) {
        const Splat& s = splats[i];
        if (!s.visible) continue;
        const double dx = u - s.u, dy = v - s.v;
        const double d2 = s.conic[0] * dx * dx + 2 * s.conic[1] * dx * dy + s.conic[2] * dy * dy;
        const double alpha = std::min(0.99, s.opacity * std::exp(-0.5 * d2));
        if (std::abs(alpha * 255.0 - 1.0) < 2e-5) close_call = true;
        if (alpha < 1.0 / 255.0) continue;
        const double w = alpha * transmittance;
        // Flat colour, or the centre colour plus the gradients at the
        // expected local coordinates B^T Sigma^-1 d.
        double colour[3];
        for (int c = 0; c < 3; ++c) {
          colour[c] = scene.sh_degree >= 0 ? s.rgb[c] : scene.features[i * nc + c];
        }
        if (scene.has_colour_gradients()) {
          const double sx = s.conic[0] * dx + s.conic[1] * dy;
          const double sy = s.conic[1] * dx + s.conic[2] * dy;
          const double lu = s.axes[0][0] * sx + s.axes[1][0] * sy;
          const double lv = s.axes[0][1] * sx + s.axes[1][1] * sy;
          for (int c = 0; c < 3; ++c) {
            colour[c] += scene.colour_gradients[6 * i + 2 * c] * lu +
                         scene.colour_gradients[6 * i + 2 * c + 1] * lv;
          }
        }
        const bool textured = scene.has_colour_gradients();
        for (int c = 0; c < nc; ++c) {
          features[c] += w * (textured && c < 3 ? colour[c] : scene.features[i * nc + c]);
        }
        for (int c = 0; c < 3; ++c) rgb[c] += w * colour[c];
        depth += w * s.depth;
        if (std::abs(w - best) <= 1e-5 * best && s.owner != best_owner) close_call = true;
        if (w > best) {
          best = w;
          best_owner = s.owner;
        }
        transmittance *= 1 - alpha;
        if (std::abs(transmittance * 1e4 - 1.0) < 1e-4) close_call = true;
        if (transmittance < 1e-4) break;
      }
      const size_t pixel = static_cast<size_t>(y) * width + x;
      if (ambiguous != nullptr) (*ambiguous)[pixel] = close_call;
      const double alpha = 1 - transmittance;
      out.alpha[pixel] = static_cast<float>(alpha);
      for (int c = 0; c < 3; ++c) out.rgb[3 * pixel + c] = static_cast<float>(rgb[c]);
      if (options.features) {
        for (int c = 0; c < nc; ++c) out.features[pixel * nc + c] = static_cast<float>(features[c]);
      }
      if (options.depth) out.depth[pixel] = alpha > 0 ? static_cast<float>(depth / alpha) : 0.f;
      if (options.instance) out.instance[pixel] = best_owner;
    }
  }
  return out;
}

}  // namespace pf::testing
