// The benchmark's street scene.
//
// World frame: x along the street (the camera looks down +x), y to the left,
// z up, metres. Splats of each kind are spread over their objects in
// proportion to surface area; their in-plane std-dev is about the local
// spacing sqrt(area / count), their normal std-dev a few percent of it.
#include "engine/render/bench_scene.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace pf {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kStreetBegin = -10, kStreetEnd = 150;   // x range, metres.
constexpr double kRoadHalfWidth = 5, kSidewalkEdge = 8;  // y, metres.
constexpr int64_t kTrackEndUs = 2'000'000;

// SplitMix64: a small, portable, reproducible generator.
class Rng {
 public:
  explicit Rng(uint64_t seed) : state_(seed) {}
  uint64_t Next() {
    uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  // Uniform in [lo, hi).
  double Uniform(double lo = 0, double hi = 1) {
    return lo + (hi - lo) * static_cast<double>(Next() >> 11) * (1.0 / 9007199254740992.0);
  }

 private:
  uint64_t state_;
};

// A planar patch: origin, two edge vectors and the normal.
struct Patch {
  Vec3 origin, edge_u, edge_v;
  double area() const { return Norm(Cross(edge_u, edge_v)); }
};

struct Object {
  std::vector<Patch> patches;  // Surfaces (empty for volumes).
  Vec3 center, radii;          // Volumes (tree crowns): an ellipsoid.
  Vec3 colour;
  uint32_t owner = 0;
  double area = 0;
  std::vector<double> patch_cumulative;  // Running sum of patch areas.
};

class SceneBuilder {
 public:
  SceneBuilder(GaussianScene* scene, Rng* rng) : scene_(scene), rng_(rng) {}

  // Adds one Gaussian with axes = columns of `axes` and std-devs `scales`.
  void Add(const Vec3& mean, const Mat3& axes, const Vec3& scales, double opacity,
           const Vec3& colour, uint32_t owner) {
    const size_t i = scene_->size();
    scene_->Resize(i + 1);
    for (int c = 0; c < 3; ++c) {
      scene_->means[3 * i + c] = static_cast<float>(mean[c]);
      scene_->log_scales[3 * i + c] = static_cast<float>(std::log(scales[c]));
    }
    const Quat q = FromMatrix(axes);
    scene_->rotations[4 * i] = static_cast<float>(q.w);
    scene_->rotations[4 * i + 1] = static_cast<float>(q.x);
    scene_->rotations[4 * i + 2] = static_cast<float>(q.y);
    scene_->rotations[4 * i + 3] = static_cast<float>(q.z);
    opacity = std::clamp(opacity, 0.01, 0.995);
    scene_->opacity_logits[i] = LogitOfOpacity(opacity);
    const int nc = scene_->num_channels;
    for (int c = 0; c < nc; ++c) {
      const double base = c < 3 ? colour[c] : colour[c % 3] * rng_->Uniform(0.5, 1.0);
      scene_->features[i * nc + c] =
          static_cast<float>(std::clamp(base + rng_->Uniform(-0.05, 0.05), 0.0, 1.0));
    }
    scene_->owners[i] = owner;
  }

  // Spreads `count` flattened splats over `objects`' patches by area.
  void AddSurfaces(const std::vector<Object>& objects, int64_t count) {
    if (count <= 0 || objects.empty()) return;
    std::vector<double> cumulative;
    double total = 0;
    for (const Object& o : objects) cumulative.push_back(total += o.area);
    const double spacing = std::sqrt(total / static_cast<double>(count));
    for (int64_t s = 0; s < count; ++s) {
      const Object& o = objects[PickIndex(cumulative)];
      const Patch& p = o.patches[PickIndex(o.patch_cumulative)];
      const Vec3 mean = p.origin + rng_->Uniform() * p.edge_u + rng_->Uniform() * p.edge_v;
      const Vec3 normal = Normalized(Cross(p.edge_u, p.edge_v));
      const double angle = rng_->Uniform(0, kPi);
      const Vec3 u0 = Normalized(p.edge_u), v0 = Cross(normal, u0);
      const Vec3 u = std::cos(angle) * u0 + std::sin(angle) * v0;
      const Vec3 v = Cross(normal, u);
      const double su = spacing * std::exp(rng_->Uniform(-1.0, 0.3));
      const double sv = su * std::exp(rng_->Uniform(-1.0, 0.0));
      const double sn = 0.03 * sv;
      Add(mean, Columns(u, v, normal), {su, sv, sn}, Opacity(), Jitter(o.colour), o.owner);
    }
  }

  // Fills tree crowns (ellipsoids) with `count` blob-like splats.
  void AddVolumes(const std::vector<Object>& objects, int64_t count) {
    if (count <= 0 || objects.empty()) return;
    std::vector<double> cumulative;
    double total = 0;
    for (const Object& o : objects) cumulative.push_back(total += o.area);
    const double spacing = std::cbrt(total / static_cast<double>(count));
    for (int64_t s = 0; s < count; ++s) {
      const Object& o = objects[PickIndex(cumulative)];
      Vec3 d;
      do {
        d = {rng_->Uniform(-1, 1), rng_->Uniform(-1, 1), rng_->Uniform(-1, 1)};
      } while (Dot(d, d) > 1);
      const Vec3 mean = o.center + Vec3{d.x * o.radii.x, d.y * o.radii.y, d.z * o.radii.z};
      const Quat q = QuatNormalized(
          {rng_->Uniform(-1, 1), rng_->Uniform(-1, 1), rng_->Uniform(-1, 1), rng_->Uniform(-1, 1)});
      const double s0 = 0.6 * spacing * std::exp(rng_->Uniform(-0.5, 0.5));
      Add(mean, ToMatrix(q), {s0, s0 * rng_->Uniform(0.3, 1.0), s0 * rng_->Uniform(0.05, 0.3)},
          rng_->Uniform(0.2, 0.9), Jitter(o.colour), 0);
    }
  }

  Vec3 Jitter(const Vec3& c) {
    const double k = rng_->Uniform(0.8, 1.2);
    return {std::clamp(c.x * k, 0.0, 1.0), std::clamp(c.y * k, 0.0, 1.0),
            std::clamp(c.z * k, 0.0, 1.0)};
  }
  // Opacities of a trained scene: mostly high, a tail of faint splats.
  double Opacity() {
    return rng_->Uniform() < 0.7 ? rng_->Uniform(0.6, 0.99) : rng_->Uniform(0.05, 0.6);
  }

  static Mat3 Columns(const Vec3& a, const Vec3& b, const Vec3& c) {
    Mat3 m;
    for (int r = 0; r < 3; ++r) m.m[r] = {a[r], b[r], c[r]};
    return m;
  }

 private:
  size_t PickIndex(const std::vector<double>& cumulative) {
    const double x = rng_->Uniform(0, cumulative.back());
    const auto it = std::upper_bound(cumulative.begin(), cumulative.end(), x);
    return std::min<size_t>(it - cumulative.begin(), cumulative.size() - 1);
  }

  GaussianScene* scene_;
  Rng* rng_;
};

Object MakeObject(std::vector<Patch> patches, const Vec3& colour, uint32_t owner = 0) {
  Object o;
  o.patches = std::move(patches);
  o.colour = colour;
  o.owner = owner;
  for (const Patch& p : o.patches) o.patch_cumulative.push_back(o.area += p.area());
  return o;
}

// The five visible faces of an axis-aligned box (no bottom) at `center`.
std::vector<Patch> BoxFaces(const Vec3& center, const Vec3& size) {
  const Vec3 lo = center - 0.5 * size;
  const Vec3 ex{size.x, 0, 0}, ey{0, size.y, 0}, ez{0, 0, size.z};
  return {{lo + ez, ex, ey}, {lo, ex, ez}, {lo + ey, ez, ex}, {lo, ez, ey}, {lo + ex, ey, ez}};
}

}  // namespace

BenchScene MakeBenchScene(int64_t num_gaussians, int width, int height, int channels,
                          uint64_t seed) {
  BenchScene bench;
  GaussianScene& scene = bench.scene;
  scene.num_channels = channels;
  Rng rng(seed);
  SceneBuilder builder(&scene, &rng);
  num_gaussians = std::max<int64_t>(num_gaussians, 1);
  scene.means.reserve(3 * num_gaussians);

  // Ground: road and two sidewalks.
  const double length = kStreetEnd - kStreetBegin;
  std::vector<Object> ground = {
      MakeObject({{{kStreetBegin, -kRoadHalfWidth, 0}, {length, 0, 0}, {0, 2 * kRoadHalfWidth, 0}}},
                 {0.32, 0.32, 0.34}),
      MakeObject({{{kStreetBegin, kRoadHalfWidth, 0.15},
                   {length, 0, 0},
                   {0, kSidewalkEdge - kRoadHalfWidth, 0}}},
                 {0.55, 0.53, 0.5}),
      MakeObject({{{kStreetBegin, -kSidewalkEdge, 0.15},
                   {length, 0, 0},
                   {0, kSidewalkEdge - kRoadHalfWidth, 0}}},
                 {0.55, 0.53, 0.5})};

  // Facades: consecutive buildings on both sides.
  std::vector<Object> facades;
  for (int side : {-1, 1}) {
    for (double x = kStreetBegin; x < kStreetEnd;) {
      const double len = std::min(rng.Uniform(8, 25), kStreetEnd - x);
      const double y = side * (kSidewalkEdge + rng.Uniform(0, 2));
      const double h = rng.Uniform(6, 20);
      const Vec3 colour{rng.Uniform(0.4, 0.9), rng.Uniform(0.35, 0.8), rng.Uniform(0.3, 0.7)};
      // Edge order makes the normal face the street.
      const Patch patch = side > 0 ? Patch{{x, y, 0}, {len, 0, 0}, {0, 0, h}}
                                   : Patch{{x, y, 0}, {0, 0, h}, {len, 0, 0}};
      facades.push_back(MakeObject({patch}, colour));
      x += len;
    }
  }

  // Poles (thin boxes) and tree crowns along the sidewalks.
  std::vector<Object> poles, trees;
  for (double x = 5; x < kStreetEnd; x += 15) {
    for (int side : {-1, 1}) {
      poles.push_back(
          MakeObject(BoxFaces({x, side * 6.0, 3.0}, {0.15, 0.15, 6.0}), {0.2, 0.2, 0.22}));
      Object tree;
      tree.center = {x + 7, side * 6.5, rng.Uniform(4, 5.5)};
      tree.radii = {rng.Uniform(1.5, 2.5), rng.Uniform(1.5, 2.5), rng.Uniform(1.5, 2.2)};
      tree.colour = {rng.Uniform(0.1, 0.25), rng.Uniform(0.35, 0.55), rng.Uniform(0.1, 0.2)};
      tree.area = tree.radii.x * tree.radii.y * tree.radii.z;  // Volume weight.
      trees.push_back(tree);
    }
  }

  // Cars: parked at the kerbs, a few driving; each an instance with a track.
  std::vector<Object> cars;
  int parked = 0, driving = 0;
  const Vec3 car_size{4.5, 1.9, 1.5};
  auto add_car = [&](const Vec3& start, const Vec3& end) {
    InstanceTrack track;
    track.id = absl::StrCat("car_", scene.instances.size());
    track.category = "car";
    for (const auto& [t, c] : {std::pair{int64_t{0}, start}, std::pair{kTrackEndUs, end}}) {
      TrackBox box;
      box.timestamp_us = t;
      box.center = c;
      box.size = car_size;
      track.boxes.push_back(box);
    }
    scene.instances.push_back(track);
    const Vec3 colour{rng.Uniform(0.1, 0.9), rng.Uniform(0.1, 0.9), rng.Uniform(0.1, 0.9)};
    cars.push_back(MakeObject(BoxFaces(start, car_size), colour,
                              static_cast<uint32_t>(scene.instances.size())));
  };
  for (double x = 8; x < kStreetEnd - 5; x += rng.Uniform(6, 12)) {
    for (int side : {-1, 1}) {
      if (rng.Uniform() < 0.6) {
        const Vec3 c{x, side * 3.9, 0.75};
        add_car(c, c);
        ++parked;
      }
    }
  }
  for (int k = 0; k < 4; ++k) {
    const double x = 15 + 25 * k + rng.Uniform(0, 10);
    const double dir = k % 2 == 0 ? 1 : -1;  // Our lane (y < 0) goes +x.
    const Vec3 c{x, -dir * 1.6, 0.75};
    add_car(c, c + Vec3{dir * 20, 0, 0});
    ++driving;
  }

  // Splat budget per kind.
  const int64_t n = num_gaussians;
  const int64_t n_facades = n * 35 / 100, n_trees = n * 12 / 100, n_cars = n * 10 / 100;
  const int64_t n_poles = n * 3 / 100, n_sky = n / 100;
  const int64_t n_ground = n - n_facades - n_trees - n_cars - n_poles - n_sky;
  builder.AddSurfaces(ground, n_ground);
  builder.AddSurfaces(facades, n_facades);
  builder.AddVolumes(trees, n_trees);
  builder.AddSurfaces(poles, n_poles);
  builder.AddSurfaces(cars, n_cars);
  // Sky: big faint splats on a far vertical wall facing the camera.
  for (int64_t s = 0; s < n_sky; ++s) {
    const Vec3 mean{400, rng.Uniform(-350, 350), rng.Uniform(20, 300)};
    const double su = rng.Uniform(8, 25);
    builder.Add(mean, SceneBuilder::Columns({0, -1, 0}, {0, 0, 1}, {-1, 0, 0}),
                {su, su * rng.Uniform(0.5, 1), 0.5}, rng.Uniform(0.3, 0.8),
                builder.Jitter({0.55, 0.7, 0.9}), 0);
  }

  // Camera: 1.6 m up in our lane, looking down the street, pitched 3 degrees
  // down; about 80 degrees horizontal field of view.
  const double fx = 0.6 * width;
  bench.camera.model = CameraModel(width, height, fx, fx, 0.5 * width, 0.5 * height);
  const double pitch = 3 * kPi / 180;
  const Vec3 forward{std::cos(pitch), 0, -std::sin(pitch)};
  const Vec3 right{0, -1, 0};
  const Vec3 down = Cross(forward, right);
  bench.camera.world_from_camera.rotation = SceneBuilder::Columns(right, down, forward);
  bench.camera.world_from_camera.translation = {0, -1.6, 1.6};
  bench.timestamp_us = kTrackEndUs / 2;

  bench.description = absl::StrFormat(
      R"({"layout":"street","seed":%d,"street_length_m":%.0f,"road_width_m":%.0f,)"
      R"("buildings":%d,"poles":%d,"trees":%d,"cars_parked":%d,"cars_driving":%d,)"
      R"("split":{"ground":%d,"facades":%d,"trees":%d,"poles":%d,"cars":%d,"sky":%d},)"
      R"("camera":{"fx":%.1f,"height_m":1.6,"pitch_deg":3},"time_us":%d})",
      seed, length, 2 * kRoadHalfWidth, facades.size(), poles.size(), trees.size(), parked, driving,
      n_ground, n_facades, n_trees, n_poles, n_cars, n_sky, fx, bench.timestamp_us);
  return bench;
}

}  // namespace pf
