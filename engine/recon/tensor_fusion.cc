// Analytic fusion as LibTorch tensor work (the full ATen API is needed here;
// no other file of the engine includes it).
#include "engine/recon/tensor_fusion.h"

#include <ATen/ATen.h>
#include <ATen/Parallel.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <exception>
#include <limits>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>

#include "absl/strings/str_cat.h"
#include "common/status_macros.h"
#include "common/thread_pool.h"
#include "engine/render/instance_pose.h"
#include "engine/render/line_poses.h"

namespace pf {
namespace {

using at::Tensor;

// Copies `values` (host memory) to a new tensor of `dtype` on `device`.
template <typename T>
Tensor ToDevice(const std::vector<T>& values, at::ScalarType host_type, at::ScalarType dtype,
                const at::Device& device) {
  const Tensor host =
      at::from_blob(const_cast<T*>(values.data()), {static_cast<int64_t>(values.size())},
                    at::TensorOptions().dtype(host_type));
  return host.to(device, dtype, /*non_blocking=*/false, /*copy=*/true);
}

// One context view, on the device.
struct DeviceView {
  Tensor rgb;      // [H * W, 3] float
  Tensor depth;    // [H * W] float, > 0
  Tensor far;      // [H * W] bool
  Tensor nearest;  // [H * W] float: least non-far depth over the clamped 3x3
                   // neighbourhood, +inf where all nine are far
  Tensor mask;     // [H * W] bool; undefined without a mask
  Tensor ego;      // [H * W] bool, the ego body; undefined without an ego mask
  const CameraModel* camera = nullptr;
  int width = 0, height = 0;
  int64_t timestamp_us = 0;
  // With a rolling shutter: the readout, and LinePoses::line_from_middle_samples
  // as [kSamples, 12] float64 (row-major rotation, then translation).
  std::optional<RollingShutter::Readout> readout;
  Tensor line_from_middle;
};

DeviceView UploadView(const FusionView& view, const at::Device& device) {
  DeviceView out;
  const ViewDepth& depth = *view.depth;
  out.camera = &view.view->camera;
  out.width = depth.width;
  out.height = depth.height;
  out.timestamp_us = view.view->timestamp_us;
  if (view.view->rolling_shutter.has_value()) {
    out.readout = view.view->rolling_shutter->readout;
    std::vector<double> samples;
    for (const Rigid& x : view.view->lines().line_from_middle_samples()) {
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) samples.push_back(x.rotation.m[r][c]);
      samples.insert(samples.end(), {x.translation.x, x.translation.y, x.translation.z});
    }
    out.line_from_middle =
        ToDevice(samples, at::kDouble, at::kDouble, device).view({LinePoses::kSamples, 12});
  }
  out.rgb = ToDevice(view.view->rgb.pixels, at::kFloat, at::kFloat, device).view({-1, 3});
  out.depth = ToDevice(depth.depth, at::kFloat, at::kFloat, device);
  out.far =
      ToDevice(depth.source, at::kByte, at::kByte, device).eq(static_cast<int>(DepthSource::kFar));
  // SeesPast of fusion.cc: every pixel of the 3x3 neighbourhood (clamped to
  // the image) is far or deeper than the limit, i.e. the least non-far depth
  // there is. The min-pool runs on a replicate-padded map (= clamping).
  // An ego-body pixel blocks the view (SeesPast): depth 0 there.
  Tensor non_far = out.depth.masked_fill(out.far, std::numeric_limits<float>::infinity());
  if (!view.view->ego.empty()) {
    out.ego = ToDevice(view.view->ego, at::kByte, at::kByte, device).ne(0);
    non_far = non_far.masked_fill(out.ego, 0.f);
  }
  const Tensor padded =
      at::replication_pad2d(non_far.view({1, 1, depth.height, depth.width}), {1, 1, 1, 1});
  out.nearest = at::max_pool2d(padded.neg(), {3, 3}, {1, 1}).neg().reshape({-1});
  if (view.mask != nullptr && !view.mask->empty()) {
    out.mask = ToDevice(*view.mask, at::kByte, at::kByte, device).ne(0);
  }
  return out;
}

// camera_from_frame[k][v] of fusion.cc as one [F, V, 12] float64 tensor
// (row-major 3x3 rotation, then translation): frame 0 is the world, frame
// k > 0 instance k's canonical frame. `camera_from_world[v]` is view v's.
Tensor CameraFromFrames(const std::vector<FusionView>& views,
                        const std::vector<Rigid>& camera_from_world,
                        const std::vector<InstanceTrack>& tracks, const at::Device& device) {
  const size_t num_views = views.size();
  std::vector<double> values((tracks.size() + 1) * num_views * 12, 0.0);
  auto put = [&](size_t frame, size_t v, const Rigid& pose) {
    double* out = &values[(frame * num_views + v) * 12];
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) out[3 * r + c] = pose.rotation.m[r][c];
    out[9] = pose.translation.x;
    out[10] = pose.translation.y;
    out[11] = pose.translation.z;
  };
  for (size_t v = 0; v < num_views; ++v) {
    put(0, v, camera_from_world[v]);
    for (size_t k = 0; k < tracks.size(); ++k) {
      // A track without boxes keeps the identity, as in fusion.cc.
      put(k + 1, v,
          tracks[k].boxes.empty()
              ? Rigid{}
              : camera_from_world[v] *
                    InstancePoseAt(tracks[k].boxes, views[v].view->timestamp_us));
    }
  }
  return ToDevice(values, at::kDouble, at::kDouble, device)
      .view({static_cast<int64_t>(tracks.size() + 1), static_cast<int64_t>(num_views), 12});
}

// Projects camera-frame points (x, y, z) [B] float64 as CameraModel::Project
// does; sets `valid` where it would return true.
void Project(const CameraModel& camera, const Tensor& x, const Tensor& y, const Tensor& z,
             Tensor* u, Tensor* v, Tensor* valid) {
  *valid = z.gt(1e-6);
  // Points behind the camera are divided by a harmless 1 and masked out.
  const Tensor safe_z = z.masked_fill(valid->logical_not(), 1.0);
  const Tensor xn = x / safe_z, yn = y / safe_z;
  Tensor xd = xn, yd = yn;
  if (camera.kind() != CameraModel::Kind::kPinhole) {
    const double max_radius = camera.max_normalized_radius();
    const Tensor r2 = xn * xn + yn * yn;
    *valid = valid->logical_and(r2.le(max_radius * max_radius));
    if (camera.kind() == CameraModel::Kind::kOpenCv) {
      const Tensor radial = 1 + r2 * (camera.k1() + r2 * (camera.k2() + r2 * camera.k3()));
      xd = xn * radial + 2 * camera.p1() * xn * yn + camera.p2() * (r2 + 2 * xn * xn);
      yd = yn * radial + camera.p1() * (r2 + 2 * yn * yn) + 2 * camera.p2() * xn * yn;
    } else {
      const Tensor r = r2.sqrt();
      const Tensor tiny = r.lt(1e-12);
      const Tensor theta = r.atan();
      Tensor theta_d;
      if (camera.kind() == CameraModel::Kind::kFTheta) {
        const Lens& lens = camera.lens();
        theta_d = at::full_like(theta, lens.ftheta[Lens::kFThetaTerms - 1]);
        for (int i = Lens::kFThetaTerms - 2; i >= 0; --i)
          theta_d = theta_d * theta + lens.ftheta[i];
      } else {
        const Tensor t2 = theta * theta;
        theta_d =
            theta *
            (1 + t2 * (camera.k1() + t2 * (camera.k2() + t2 * (camera.k3() + t2 * camera.k4()))));
      }
      const Tensor safe_r = r.masked_fill(tiny, 1.0);
      xd = at::where(tiny, xn, xn * theta_d / safe_r);
      yd = at::where(tiny, yn, yn * theta_d / safe_r);
    }
  }
  *u = camera.fx() * xd + camera.cx();
  *v = camera.fy() * yd + camera.cy();
}

// Moves camera-frame points (x, y, z) of a rolling-shutter view's middle
// line, projected to (u, v), to the camera of the line that reads each and
// projects them again, twice (as OntoItsLine of fusion.cc).
void OntoTheirLines(const DeviceView& view, Tensor* x, Tensor* y, Tensor* z, Tensor* u, Tensor* v,
                    Tensor* valid) {
  const Tensor mx = *x, my = *y, mz = *z;
  // ReadoutFractionOf (rasterizer.h) on tensors.
  const double rows = std::max(view.height - 1, 1), columns = std::max(view.width - 1, 1);
  for (int step = 0; step < 2; ++step) {
    Tensor f;
    switch (*view.readout) {
      case RollingShutter::Readout::kTopToBottom:
        f = (*v - 0.5) / rows;
        break;
      case RollingShutter::Readout::kBottomToTop:
        f = 1 - (*v - 0.5) / rows;
        break;
      case RollingShutter::Readout::kLeftToRight:
        f = (*u - 0.5) / columns;
        break;
      case RollingShutter::Readout::kRightToLeft:
        f = 1 - (*u - 0.5) / columns;
        break;
    }
    // Points that project nowhere are masked out by `valid`; any line will do.
    const Tensor s = f.nan_to_num(0.5, 0.5, 0.5).clamp(0.0, 1.0) * (LinePoses::kSamples - 1);
    const Tensor k = s.floor().clamp_max(LinePoses::kSamples - 2);
    const Tensor w = (s - k).unsqueeze(1);
    const Tensor index = k.to(at::kLong);
    const Tensor a = view.line_from_middle.index_select(0, index);
    const Tensor d = a + w * (view.line_from_middle.index_select(0, index + 1) - a);
    *x = d.select(1, 0) * mx + d.select(1, 1) * my + d.select(1, 2) * mz + d.select(1, 9);
    *y = d.select(1, 3) * mx + d.select(1, 4) * my + d.select(1, 5) * mz + d.select(1, 10);
    *z = d.select(1, 6) * mx + d.select(1, 7) * my + d.select(1, 8) * mz + d.select(1, 11);
    Tensor seen;
    Project(*view.camera, *x, *y, *z, u, v, &seen);
    *valid = valid->logical_and(seen);
  }
}

// Bilinear colours [B, 3] float of continuous pixels (u, v) [B] float64 of a
// [H * W, 3] image, as SampleRgb of fusion.cc (pixel centres at +0.5,
// clamped to the image; ego-body pixels weigh nothing).
Tensor SampleRgb(const DeviceView& view, const Tensor& u, const Tensor& v) {
  const Tensor x = (u - 0.5).clamp(0.0, view.width - 1);
  const Tensor y = (v - 0.5).clamp(0.0, view.height - 1);
  const Tensor x0 = x.floor(), y0 = y.floor();
  const Tensor fx = (x - x0).to(at::kFloat).unsqueeze(1);
  const Tensor fy = (y - y0).to(at::kFloat).unsqueeze(1);
  const Tensor ix0 = x0.to(at::kLong), iy0 = y0.to(at::kLong);
  const Tensor ix1 = (ix0 + 1).clamp_max(view.width - 1);
  const Tensor iy1 = (iy0 + 1).clamp_max(view.height - 1);
  const Tensor corners[4] = {iy0 * view.width + ix0, iy0 * view.width + ix1, iy1 * view.width + ix0,
                             iy1 * view.width + ix1};
  Tensor weights[4] = {(1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy};
  Tensor sum = at::zeros_like(fx);
  for (int k = 0; k < 4; ++k) {
    if (view.ego.defined()) {
      weights[k] = weights[k].masked_fill(view.ego.take(corners[k]).unsqueeze(1), 0.f);
    }
    sum = sum + weights[k];
  }
  Tensor rgb = at::zeros({fx.size(0), 3}, view.rgb.options());
  for (int k = 0; k < 4; ++k) rgb = rgb + view.rgb.index_select(0, corners[k]) * weights[k];
  return view.ego.defined() ? rgb / sum.clamp_min(1e-12f) : rgb;
}

// Fuses queries [begin, end) into `out`. Static queries are moved into each
// view by its camera-from-world pose (scalars), instance queries by their
// frame's pose gathered per query. Past the projection, a view's work runs
// on the queries that land in its image only (gathered by index, about half
// of them), and the sums are scattered back; the indices are unique, so
// each query's sums add up view after view as in fusion.cc.
void FuseBatch(const QuerySet& queries, int64_t begin, int64_t end,
               const std::vector<DeviceView>& views, const std::vector<Rigid>& camera_from_world,
               const Tensor& camera_from_frame, const Tensor& view_times,
               const FusionOptions& options, const at::Device& device, FusedQueries* out) {
  const int64_t count = end - begin;
  auto slice = [&](const auto& values, int64_t width, at::ScalarType type) {
    return at::from_blob(const_cast<void*>(static_cast<const void*>(values.data() + begin * width)),
                         {count * width}, at::TensorOptions().dtype(type));
  };
  const Tensor positions =
      slice(queries.positions, 3, at::kFloat).to(device, at::kDouble).view({count, 3});
  const Tensor px = positions.select(1, 0).contiguous(), py = positions.select(1, 1).contiguous(),
               pz = positions.select(1, 2).contiguous();
  const Tensor pxf = px.to(at::kFloat), pyf = py.to(at::kFloat), pzf = pz.to(at::kFloat);
  const Tensor query_rgb = slice(queries.rgb, 3, at::kFloat).to(device).view({count, 3});
  const Tensor query_depth = slice(queries.depths, 1, at::kFloat).to(device);
  const Tensor source = slice(queries.views, 1, at::kInt).to(device, at::kLong);
  const Tensor owners = slice(queries.owners, 1, at::kInt).to(device, at::kLong);
  const Tensor is_static = owners.eq(0);
  const Tensor is_far = slice(queries.far, 1, at::kByte).to(device).ne(0);
  const Tensor query_time = view_times.index_select(0, source);
  const Tensor dynamic = owners.gt(0).nonzero().squeeze(1);
  const Tensor dynamic_owners = owners.index_select(0, dynamic);
  const Tensor dx = px.index_select(0, dynamic), dy = py.index_select(0, dynamic),
               dz = pz.index_select(0, dynamic);

  const at::TensorOptions on_device = at::TensorOptions().device(device);
  // Per query: weighted colour sum (3), weight sum, observations,
  // contradictions; one scatter per view adds a view's six at once.
  Tensor sums = at::zeros({count, 6}, on_device.dtype(at::kDouble));
  Tensor max_gap_us = at::zeros({count}, on_device.dtype(at::kLong));
  const float tol = static_cast<float>(options.visibility_tolerance);
  const float inf = std::numeric_limits<float>::infinity();

  for (size_t v = 0; v < views.size(); ++v) {
    const DeviceView& view = views[v];
    const Mat3& r = camera_from_world[v].rotation;
    const Vec3& t = camera_from_world[v].translation;
    // A float32 pass culls the static queries that surely miss the image,
    // with margins far beyond float rounding (1 m in depth, 10 % + 2 px of
    // the image sideways; sideways only for pinhole cameras and points over
    // 0.5 m ahead; none for a rolling-shutter view, whose lines see from
    // other poses); the exact float64 test below runs on the rest.
    const Tensor czf =
        pxf * float(r.m[2][0]) + pyf * float(r.m[2][1]) + pzf * float(r.m[2][2]) + float(t.z);
    Tensor maybe = czf.gt(-1.f);
    if (view.camera->kind() == CameraModel::Kind::kPinhole) {
      const Tensor cxf =
          pxf * float(r.m[0][0]) + pyf * float(r.m[0][1]) + pzf * float(r.m[0][2]) + float(t.x);
      const Tensor cyf =
          pxf * float(r.m[1][0]) + pyf * float(r.m[1][1]) + pzf * float(r.m[1][2]) + float(t.y);
      const Tensor ahead = czf.gt(0.5f);
      const Tensor safe = czf.clamp_min(0.5f);
      const Tensor uf = cxf / safe * float(view.camera->fx()) + float(view.camera->cx());
      const Tensor vf = cyf / safe * float(view.camera->fy()) + float(view.camera->cy());
      const float mu = 0.1f * view.width + 2, mv = 0.1f * view.height + 2;
      const Tensor inside = uf.gt(-mu)
                                .logical_and(uf.lt(view.width + mu))
                                .logical_and(vf.gt(-mv))
                                .logical_and(vf.lt(view.height + mv));
      maybe = maybe.logical_and(ahead.logical_not().logical_or(inside));
    }
    if (view.readout.has_value()) maybe = at::ones_like(maybe);
    maybe = maybe.logical_or(is_static.logical_not());
    const Tensor candidates = maybe.nonzero().squeeze(1);
    if (candidates.numel() == 0) continue;

    // pc = R p + t exactly, summed in the order of Mat3 * Vec3: the view's
    // camera-from-world for static queries, their frame's pose at the view's
    // time for instance queries.
    const Tensor cpx = px.index_select(0, candidates), cpy = py.index_select(0, candidates),
                 cpz = pz.index_select(0, candidates);
    Tensor cx = cpx * r.m[0][0] + cpy * r.m[0][1] + cpz * r.m[0][2] + t.x;
    Tensor cy = cpx * r.m[1][0] + cpy * r.m[1][1] + cpz * r.m[1][2] + t.y;
    Tensor cz = cpx * r.m[2][0] + cpy * r.m[2][1] + cpz * r.m[2][2] + t.z;
    if (dynamic.numel() > 0) {
      const Tensor pose =
          camera_from_frame.select(1, static_cast<int64_t>(v)).index_select(0, dynamic_owners);
      auto row = [&](int k) {
        return pose.select(1, 3 * k) * dx + pose.select(1, 3 * k + 1) * dy +
               pose.select(1, 3 * k + 2) * dz + pose.select(1, 9 + k);
      };
      // Where each instance query sits among the candidates (all of them are).
      const Tensor slot = at::searchsorted(candidates, dynamic);
      cx.index_copy_(0, slot, row(0));
      cy.index_copy_(0, slot, row(1));
      cz.index_copy_(0, slot, row(2));
    }
    Tensor u, w_pixel, valid;
    Project(*view.camera, cx, cy, cz, &u, &w_pixel, &valid);
    if (view.readout.has_value()) OntoTheirLines(view, &cx, &cy, &cz, &u, &w_pixel, &valid);
    // NaN or infinite pixels of invalid projections fail these tests too.
    Tensor fx = u.floor(), fy = w_pixel.floor();
    valid = valid.logical_and(fx.ge(0))
                .logical_and(fy.ge(0))
                .logical_and(fx.lt(view.width))
                .logical_and(fy.lt(view.height));
    const Tensor local = valid.nonzero().squeeze(1);
    Tensor index = candidates.index_select(0, local);
    Tensor pixel = fy.index_select(0, local).to(at::kLong) * view.width +
                   fx.index_select(0, local).to(at::kLong);
    u = u.index_select(0, local);
    w_pixel = w_pixel.index_select(0, local);
    cz = cz.index_select(0, local);
    Tensor is_source = source.index_select(0, index).eq(static_cast<int64_t>(v));
    if (view.mask.defined() || view.ego.defined()) {
      // Static queries of other views are not seen inside a dynamic mask, and
      // no query is seen through the ego vehicle's body.
      Tensor hidden = view.mask.defined() ? is_static.index_select(0, index)
                                                .logical_and(is_source.logical_not())
                                                .logical_and(view.mask.take(pixel))
                                          : at::zeros_like(is_source);
      if (view.ego.defined()) {
        hidden = hidden.logical_or(view.ego.take(pixel).logical_and(is_source.logical_not()));
      }
      const Tensor keep = hidden.logical_not();
      index = index.masked_select(keep);
      pixel = pixel.masked_select(keep);
      is_source = is_source.masked_select(keep);
      u = u.masked_select(keep);
      w_pixel = w_pixel.masked_select(keep);
      cz = cz.masked_select(keep);
    }
    if (index.numel() == 0) continue;

    const Tensor z = cz.to(at::kFloat);
    const Tensor far = is_far.index_select(0, index);
    const Tensor depth = view.depth.take(pixel);
    const Tensor pixel_far = view.far.take(pixel);
    // d: 0 for the source view and for far-layer queries.
    const Tensor d =
        ((z - depth) / z).masked_fill(pixel_far, -inf).masked_fill(is_source.logical_or(far), 0.f);
    const Tensor contradicts = is_source.logical_or(far)
                                   .logical_not()
                                   .logical_and(d.lt(-tol))
                                   .logical_and(view.nearest.take(pixel).gt(z * (1 + tol)));
    // Observation: the source view; a far query where the view sees far; any
    // other query within the tolerance.
    const Tensor observes = at::where(far, pixel_far, d.abs().le(tol)).logical_or(is_source);
    const Tensor gap = (view_times[static_cast<int64_t>(v)] - query_time.index_select(0, index))
                           .abs()
                           .masked_fill(observes.logical_not(), 0);
    max_gap_us.index_copy_(0, index, at::maximum(max_gap_us.index_select(0, index), gap));

    Tensor w;
    Tensor included = observes;
    switch (options.weights) {
      case FusionWeights::kDepthSoftmax:
        w = (d.abs().to(at::kDouble).neg() / options.tau).exp();
        break;
      case FusionWeights::kPlainAverage:
        w = at::ones({index.numel()}, on_device.dtype(at::kDouble));
        break;
      case FusionWeights::kNoDepth:
      default:
        w = at::ones({index.numel()}, on_device.dtype(at::kDouble));
        included = at::ones_like(observes);
        break;
    }
    if (options.resolution_weighting && options.weights != FusionWeights::kNoDepth) {
      const Tensor ratio =
          (query_depth.index_select(0, index) / z.clamp_min(1e-6f)).to(at::kDouble);
      w = w * (ratio * ratio);
    }
    w = w.masked_fill(included.logical_not(), 0.0);
    const Tensor colour = SampleRgb(view, u, w_pixel);
    sums.index_add_(
        0, index,
        at::cat({w.unsqueeze(1) * colour.to(at::kDouble), w.unsqueeze(1),
                 observes.to(at::kDouble).unsqueeze(1), contradicts.to(at::kDouble).unsqueeze(1)},
                1));
  }
  const Tensor rgb = sums.narrow(1, 0, 3);
  const Tensor sum_w = sums.select(1, 3);
  Tensor observed = sums.select(1, 4).to(at::kInt);
  const Tensor contradicted = sums.select(1, 5).to(at::kInt);

  const Tensor has_weight = sum_w.gt(0);
  const Tensor fused_rgb = at::where(
      has_weight.unsqueeze(1),
      (rgb / sum_w.masked_fill(has_weight.logical_not(), 1.0).unsqueeze(1)).to(at::kFloat),
      query_rgb);
  observed = observed.clamp_min(1);
  const Tensor agreement = observed.to(at::kFloat) / (observed + contradicted).to(at::kFloat);
  Tensor lifespans = at::full({count}, inf, on_device.dtype(at::kFloat));
  if (options.lifespan) {
    const Tensor fades = is_static.logical_and(contradicted.gt(0));
    lifespans = at::where(fades, (max_gap_us.to(at::kDouble) * 1e-6).to(at::kFloat), lifespans);
  }

  // Back to the host, into the output arrays.
  auto copy_out = [&](const Tensor& tensor, void* dst, size_t bytes) {
    const Tensor host = tensor.to(at::kCPU).contiguous();
    std::memcpy(dst, host.data_ptr(), bytes);
  };
  copy_out(fused_rgb, out->rgb.data() + 3 * begin, sizeof(float) * 3 * count);
  copy_out(agreement, out->agreement.data() + begin, sizeof(float) * count);
  copy_out(lifespans, out->lifespans.data() + begin, sizeof(float) * count);
  const Tensor observations = observed.clamp_max(65535).to(at::kCPU).contiguous();
  const int32_t* counts = observations.data_ptr<int32_t>();
  for (int64_t i = 0; i < count; ++i) {
    out->observations[begin + i] = static_cast<uint16_t>(counts[i]);
  }
}

// ATen ops run single-threaded (its OpenMP threads spin at every op's
// barrier and crawl on a loaded machine or under a container's CPU quota);
// on the CPU the batches run in parallel on the engine's pool instead.
void SingleThreadedTorch() {
  static std::once_flag once;
  std::call_once(once, [] { at::set_num_threads(1); });
}

}  // namespace

TensorProjection ProjectWithTensors(const CameraModel& camera, const std::vector<double>& x,
                                    const std::vector<double>& y, const std::vector<double>& z) {
  const at::Device cpu(at::kCPU);
  Tensor u, v, valid;
  Project(camera, ToDevice(x, at::kDouble, at::kDouble, cpu),
          ToDevice(y, at::kDouble, at::kDouble, cpu), ToDevice(z, at::kDouble, at::kDouble, cpu),
          &u, &v, &valid);
  TensorProjection out;
  const Tensor u_host = u.contiguous(), v_host = v.contiguous();
  const Tensor valid_host = valid.to(at::kByte).contiguous();
  const double* u_data = u_host.data_ptr<double>();
  const double* v_data = v_host.data_ptr<double>();
  const uint8_t* valid_data = valid_host.data_ptr<uint8_t>();
  for (size_t i = 0; i < x.size(); ++i) {
    out.u.push_back(u_data[i]);
    out.v.push_back(v_data[i]);
    out.valid.push_back(valid_data[i] != 0);
  }
  return out;
}

absl::StatusOr<FusedQueries> FuseQueriesOnDevice(const QuerySet& queries,
                                                 const std::vector<FusionView>& views,
                                                 const std::vector<InstanceTrack>& tracks,
                                                 const FusionOptions& options,
                                                 const ComputeDevice& device, int64_t batch) {
  RETURN_IF_ERROR(CheckComputeDevice(device, "device"));
  if (batch < 0) return absl::InvalidArgumentError("batch: must not be negative");
  const bool on_cpu = device.kind == ComputeDevice::Kind::kCpu;
  if (batch == 0) batch = on_cpu ? kCpuFusionBatch : kGpuFusionBatch;
  const size_t n = queries.size();
  FusedQueries out = NewFusedQueries(n);
  if (n == 0) return out;
  SingleThreadedTorch();
  try {
    const at::Device on =
        on_cpu ? at::Device(at::kCPU) : at::Device(at::kCUDA, static_cast<int8_t>(device.index));
    std::vector<DeviceView> device_views;
    std::vector<Rigid> camera_from_world;
    std::vector<int64_t> times;
    for (const FusionView& view : views) {
      device_views.push_back(UploadView(view, on));
      // A rolling-shutter view's middle line (OntoTheirLines moves each point
      // to its own line).
      camera_from_world.push_back(view.view->rolling_shutter.has_value()
                                      ? view.view->lines().MiddleWorldFromCamera().Inverse()
                                      : view.view->world_from_camera.Inverse());
      times.push_back(view.view->timestamp_us);
    }
    const Tensor camera_from_frame = CameraFromFrames(views, camera_from_world, tracks, on);
    const Tensor view_times = ToDevice(times, at::kLong, at::kLong, on);
    const int64_t batches = (static_cast<int64_t>(n) + batch - 1) / batch;
    auto run = [&](int64_t b) {
      const int64_t begin = b * batch;
      const int64_t end = std::min<int64_t>(begin + batch, static_cast<int64_t>(n));
      FuseBatch(queries, begin, end, device_views, camera_from_world, camera_from_frame, view_times,
                options, on, &out);
    };
    if (!on_cpu) {
      for (int64_t b = 0; b < batches; ++b) run(b);
    } else {
      // Batches write disjoint ranges of `out`; the first error is kept.
      std::mutex mutex;
      std::string error;
      DefaultThreadPool().ParallelFor(0, batches, 1, [&](int64_t first, int64_t last) {
        for (int64_t b = first; b < last; ++b) {
          try {
            run(b);
          } catch (const std::exception& e) {
            std::lock_guard<std::mutex> lock(mutex);
            if (error.empty()) error = e.what();
          }
        }
      });
      if (!error.empty()) throw std::runtime_error(error);
    }
  } catch (const std::exception& e) {
    return absl::InternalError(
        absl::StrCat("fusion on ", device.ToString(), " failed in LibTorch: ", e.what()));
  }
  return out;
}

}  // namespace pf
