// Analytic spatial-temporal fusion of queries over the context views.
#include "engine/recon/fusion.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include "common/thread_pool.h"
#include "engine/camera/image_pixel.h"
#include "engine/render/instance_pose.h"
#include "engine/render/line_poses.h"

namespace pf {
namespace {

// Moves `pc`, a point in a rolling-shutter view's middle-line camera frame
// projected to (u, v), to the camera of the line that reads it and projects
// it again, twice (LinePoses::Project iterates further and also tries the
// first and last lines for points the middle line cannot see); false when
// that line does not see it.
bool OntoItsLine(const LinePoses& lines, Vec3* pc, double* u, double* v) {
  const Vec3 middle = *pc;
  for (int step = 0; step < 2; ++step) {
    *pc = lines.LineFromMiddle(lines.Fraction(*u, *v)) * middle;
    if (!lines.camera().Project(*pc, u, v)) return false;
  }
  return true;
}

// Bilinear colour of continuous pixel (u, v) of `view`, pixel centres at
// +0.5. Pixels on the ego body get no weight (the others' weights are
// renormalised); the pixel (u, v) lies in, never on the body here, has at
// least a quarter of it.
void SampleRgb(const ContextView& view, double u, double v, float out[3]) {
  const ImageF& image = view.rgb;
  const double x = std::clamp(u - 0.5, 0.0, double(image.width - 1));
  const double y = std::clamp(v - 0.5, 0.0, double(image.height - 1));
  const int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
  const int x1 = std::min(x0 + 1, image.width - 1), y1 = std::min(y0 + 1, image.height - 1);
  const float fx = float(x - x0), fy = float(y - y0);
  const int xs[4] = {x0, x1, x0, x1}, ys[4] = {y0, y0, y1, y1};
  float w[4] = {(1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy};
  float sum = 0;
  for (int k = 0; k < 4; ++k) {
    if (view.is_ego(static_cast<size_t>(ys[k]) * image.width + xs[k])) w[k] = 0;
    sum += w[k];
  }
  for (int c = 0; c < 3; ++c) {
    float value = 0;
    for (int k = 0; k < 4; ++k) value += w[k] * image.at(xs[k], ys[k], c);
    out[c] = view.ego.empty() ? value : value / std::max(sum, 1e-12f);
  }
}

// True when every pixel of the 3x3 neighbourhood of (x, y) sees further than
// `limit` (or is far layer while the query is not). A pixel on the ego body
// sees nothing past it.
bool SeesPast(const ContextView& view, const ViewDepth& depth, int x, int y, float limit) {
  for (int dy = -1; dy <= 1; ++dy) {
    for (int dx = -1; dx <= 1; ++dx) {
      const int xx = std::clamp(x + dx, 0, depth.width - 1);
      const int yy = std::clamp(y + dy, 0, depth.height - 1);
      const size_t j = static_cast<size_t>(yy) * depth.width + xx;
      if (view.is_ego(j)) return false;
      if (!depth.is_far(j) && depth.depth[j] <= limit) return false;
    }
  }
  return true;
}

}  // namespace

FusedQueries NewFusedQueries(size_t n) {
  FusedQueries out;
  out.rgb.assign(n * 3, 0.f);
  out.agreement.assign(n, 1.f);
  out.lifespans.assign(n, std::numeric_limits<float>::infinity());
  out.observations.assign(n, 0);
  return out;
}

FusedQueries UnfusedQueries(const QuerySet& queries) {
  FusedQueries out;
  out.rgb = queries.rgb;
  out.agreement.assign(queries.size(), 1.f);
  out.lifespans.assign(queries.size(), std::numeric_limits<float>::infinity());
  out.observations.assign(queries.size(), 1);
  return out;
}

FusedQueries FuseQueries(const QuerySet& queries, const std::vector<FusionView>& views,
                         const std::vector<InstanceTrack>& tracks, const FusionOptions& options) {
  const size_t n = queries.size();
  const size_t num_views = views.size();
  FusedQueries out = NewFusedQueries(n);

  // camera_from_frame[k][v]: frame k = 0 world, k > 0 instance k's canonical.
  std::vector<std::vector<Rigid>> camera_from_frame(tracks.size() + 1,
                                                    std::vector<Rigid>(num_views));
  // A rolling-shutter view's transforms are its middle line's; each point
  // then moves to the line that reads it (LineFromMiddle).
  std::vector<std::optional<LinePoses>> lines(num_views);
  for (size_t v = 0; v < num_views; ++v) {
    Rigid camera_from_world = views[v].view->world_from_camera.Inverse();
    if (views[v].view->rolling_shutter.has_value()) {
      lines[v] = views[v].view->lines();
      camera_from_world = lines[v]->MiddleWorldFromCamera().Inverse();
    }
    camera_from_frame[0][v] = camera_from_world;
    for (size_t k = 0; k < tracks.size(); ++k) {
      if (tracks[k].boxes.empty()) continue;
      camera_from_frame[k + 1][v] =
          camera_from_world * InstancePoseAt(tracks[k].boxes, views[v].view->timestamp_us);
    }
  }
  const float inf = std::numeric_limits<float>::infinity();
  const float tol = static_cast<float>(options.visibility_tolerance);

  DefaultThreadPool().ParallelFor(0, static_cast<int64_t>(n), 2048, [&](int64_t b, int64_t e) {
    for (int64_t i = b; i < e; ++i) {
      const uint32_t owner = queries.owners[i];
      const int source = queries.views[i];
      const bool is_far = queries.far[i] != 0;
      const Vec3 p = queries.position(i);
      const int64_t t_query = views[source].view->timestamp_us;
      double sum_w = 0, rgb[3] = {0, 0, 0};
      int observed = 0, contradicted = 0;
      int64_t max_gap_us = 0;
      for (size_t v = 0; v < num_views; ++v) {
        const FusionView& fv = views[v];
        Vec3 pc = camera_from_frame[owner][v] * p;
        double u, vv;
        if (!fv.view->camera.Project(pc, &u, &vv)) continue;
        if (lines[v].has_value() && !OntoItsLine(*lines[v], &pc, &u, &vv)) continue;
        int x, y;
        if (!PixelInImage(u, vv, fv.depth->width, fv.depth->height, &x, &y)) continue;
        const size_t j = static_cast<size_t>(y) * fv.depth->width + x;
        const bool is_source = static_cast<int>(v) == source;
        // A pixel on the ego vehicle's body sees the body, not the query (and
        // is never a source: lifting skips it).
        if (!is_source && fv.view->is_ego(j)) continue;
        if (owner == 0 && !is_source && fv.mask != nullptr && (*fv.mask)[j] != 0) continue;
        const float z = static_cast<float>(pc.z);
        float d = 0.f;  // Relative depth difference.
        bool observes = true;
        if (!is_source) {
          if (is_far) {
            observes = fv.depth->is_far(j);
          } else {
            d = fv.depth->is_far(j) ? -inf : (z - fv.depth->depth[j]) / z;
            if (d < -tol && SeesPast(*fv.view, *fv.depth, x, y, z * (1 + tol))) ++contradicted;
            observes = std::abs(d) <= tol;
          }
        }
        if (observes) {
          ++observed;
          max_gap_us = std::max(max_gap_us, std::abs(fv.view->timestamp_us - t_query));
        }
        double w;
        switch (options.weights) {
          case FusionWeights::kDepthSoftmax:
            if (!observes) continue;
            w = std::exp(-std::abs(d) / options.tau);
            break;
          case FusionWeights::kPlainAverage:
            if (!observes) continue;
            w = 1.0;
            break;
          case FusionWeights::kNoDepth:
          default:
            w = 1.0;
            break;
        }
        if (options.resolution_weighting && options.weights != FusionWeights::kNoDepth) {
          const double ratio = queries.depths[i] / std::max(1e-6f, z);
          w *= ratio * ratio;
        }
        float c[3];
        SampleRgb(*fv.view, u, vv, c);
        for (int ch = 0; ch < 3; ++ch) rgb[ch] += w * c[ch];
        sum_w += w;
      }
      if (sum_w > 0) {
        for (int ch = 0; ch < 3; ++ch) out.rgb[3 * i + ch] = static_cast<float>(rgb[ch] / sum_w);
      } else {
        for (int ch = 0; ch < 3; ++ch) out.rgb[3 * i + ch] = queries.rgb[3 * i + ch];
      }
      observed = std::max(observed, 1);
      out.observations[i] = static_cast<uint16_t>(std::min(observed, 65535));
      out.agreement[i] = float(observed) / float(observed + contradicted);
      if (options.lifespan && owner == 0 && contradicted > 0) {
        out.lifespans[i] = static_cast<float>(max_gap_us * 1e-6);
      }
    }
  });
  return out;
}

}  // namespace pf
