// Procedural generation of the synthetic driving scene (see synth_scene.h).
#include "engine/synth/synth_scene.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "absl/strings/str_cat.h"
#include "engine/synth/synth_random.h"

namespace pf {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kDeg = kPi / 180.0;

// Rig numbers.
constexpr double kHorizontalFovDeg = 75.0;
constexpr double kFThetaHalfFovDeg = 60.0;
constexpr double kCameraYawSpacingDeg = 40.0;
constexpr double kCameraPitchDeg = -3.0;

// Extent of the built-up area along the road.
constexpr double kStreetBeginX = -120.0;
constexpr double kStreetEndX = 260.0;

// Vehicles are drawn so that they do not collide over this long.
constexpr double kVehicleCheckSeconds = 2.0;

// Returns the option range error for `name`.
absl::Status OutOfRange(const std::string& name, const std::string& range, int64_t value) {
  return absl::InvalidArgumentError(absl::StrCat(name, ": must be in ", range, ", got ", value));
}

// Returns a facade colour from a small palette of plausible tones.
Vec3 FacadeColour(SynthRng& rng) {
  static constexpr double kPalette[][3] = {
      {0.72, 0.62, 0.50}, {0.62, 0.36, 0.28}, {0.80, 0.78, 0.72}, {0.55, 0.58, 0.62},
      {0.85, 0.74, 0.52}, {0.45, 0.42, 0.40}, {0.70, 0.50, 0.42}, {0.60, 0.68, 0.66},
  };
  const auto& c = kPalette[rng.UniformInt(0, 7)];
  const double tone = rng.Uniform(0.9, 1.08);
  return {std::min(1.0, c[0] * tone), std::min(1.0, c[1] * tone), std::min(1.0, c[2] * tone)};
}

// Returns a paint colour for a vehicle.
Vec3 PaintColour(SynthRng& rng) {
  static constexpr double kPalette[][3] = {
      {0.75, 0.08, 0.07}, {0.10, 0.22, 0.60}, {0.90, 0.90, 0.88}, {0.12, 0.12, 0.13},
      {0.55, 0.57, 0.60}, {0.08, 0.42, 0.20}, {0.92, 0.70, 0.10}, {0.35, 0.18, 0.45},
  };
  const auto& c = kPalette[rng.UniformInt(0, 7)];
  return {c[0], c[1], c[2]};
}

// Appends a box with corners sorted per axis.
void AddBox(std::vector<StaticBox>& boxes, Vec3 a, Vec3 b, StaticKind kind, uint32_t seed,
            const Vec3& albedo) {
  StaticBox box;
  box.lo = {std::min(a.x, b.x), std::min(a.y, b.y), std::min(a.z, b.z)};
  box.hi = {std::max(a.x, b.x), std::max(a.y, b.y), std::max(a.z, b.z)};
  box.kind = kind;
  box.texture_seed = seed;
  box.albedo = albedo;
  boxes.push_back(box);
}

// Adds a row of buildings along the road on `side` (+1 left, -1 right) over
// x in [x_begin, x_end), facades at |y| = facade_y plus a random setback.
void AddBuildingRowAlongX(SynthRng& rng, int side, double x_begin, double x_end, double facade_y,
                          std::vector<StaticBox>& boxes) {
  double x = x_begin;
  while (x_end - x > 2.0) {
    if (rng.Unit() < 0.25) x += rng.Uniform(1.5, 3.0);  // An alley.
    const double width = std::min(rng.Uniform(8.0, 22.0), x_end - x);
    if (width < 2.0) break;
    const double near_y = facade_y + rng.Uniform(0.0, 1.5);
    const double far_y = near_y + rng.Uniform(10.0, 18.0);
    const double height = rng.Uniform(7.0, 24.0);
    AddBox(boxes, {x, side * near_y, 0.0}, {x + width, side * far_y, height}, StaticKind::kBuilding,
           rng.NextU32(), FacadeColour(rng));
    x += width;
  }
}

// Adds a row of buildings along the cross street on the side x < x_facade
// (`side` = -1) or x > x_facade (`side` = +1), over |y| in [y_begin, y_end)
// on both halves of the street.
void AddBuildingRowAlongY(SynthRng& rng, int side, double x_facade, double y_begin, double y_end,
                          std::vector<StaticBox>& boxes) {
  for (int half : {-1, 1}) {
    double y = y_begin;
    while (y_end - y > 2.0) {
      if (rng.Unit() < 0.25) y += rng.Uniform(1.5, 3.0);
      const double width = std::min(rng.Uniform(8.0, 20.0), y_end - y);
      if (width < 2.0) break;
      const double near_x = x_facade + side * rng.Uniform(0.0, 1.5);
      const double far_x = near_x + side * rng.Uniform(10.0, 16.0);
      const double height = rng.Uniform(7.0, 22.0);
      AddBox(boxes, {near_x, half * y, 0.0}, {far_x, half * (y + width), height},
             StaticKind::kBuilding, rng.NextU32(), FacadeColour(rng));
      y += width;
    }
  }
}

// Adds lamp posts (a post and an arm over the road) along both kerbs.
void AddPoles(SynthRng& rng, const RoadLayout& road, std::vector<StaticBox>& boxes) {
  const Vec3 metal{0.42, 0.44, 0.46};
  const double pole_y = road.half_width + 0.6;
  for (int side : {-1, 1}) {
    double x = kStreetBeginX + rng.Uniform(0.0, 10.0);
    while (x < kStreetEndX - 5.0) {
      if (std::abs(x - road.junction_x) > road.junction_half_width + 2.0) {
        const double height = rng.Uniform(5.5, 7.0);
        const uint32_t seed = rng.NextU32();
        AddBox(boxes, {x - 0.09, side * pole_y - 0.09, road.kerb_height},
               {x + 0.09, side * pole_y + 0.09, height}, StaticKind::kPole, seed, metal);
        AddBox(boxes, {x - 0.06, side * (pole_y - 1.8), height - 0.14},
               {x + 0.06, side * pole_y, height}, StaticKind::kPole, seed, metal);
      }
      x += rng.Uniform(14.0, 20.0);
    }
  }
}

// Builds the parts of a vehicle of `category` inside a box of `size`.
std::vector<VehiclePart> VehicleParts(const std::string& category, const Vec3& size) {
  const double l = size.x / 2, w = size.y / 2, h = size.z / 2;
  const double wheel_h = 0.62, clearance = 0.28;
  std::vector<VehiclePart> parts;
  const bool van = category == "van";
  const double body_top = -h + clearance + (van ? 0.9 : 0.72);
  parts.push_back({{-l, -w, -h + clearance}, {l, w, body_top}, VehiclePartKind::kBody});
  const double cabin_back = van ? -l : -l + 0.22 * size.x;
  const double cabin_front = van ? l - 0.85 : l - 0.32 * size.x;
  parts.push_back(
      {{cabin_back, -w + 0.08, body_top}, {cabin_front, w - 0.08, h}, VehiclePartKind::kCabin});
  for (double sx : {-1.0, 1.0}) {
    for (double sy : {-1.0, 1.0}) {
      const double xc = sx * (l - 0.85);
      const double y_out = sy * (w - 0.01), y_in = sy * (w - 0.27);
      parts.push_back({{xc - 0.31, std::min(y_out, y_in), -h},
                       {xc + 0.31, std::max(y_out, y_in), -h + wheel_h},
                       VehiclePartKind::kWheel});
    }
  }
  return parts;
}

// Makes a vehicle of a random category and colour at `position` (ground
// point of its centre) with the given motion.
Vehicle MakeVehicle(SynthRng& rng, int index, const Vec3& ground_position, double heading,
                    double speed, double yaw_rate) {
  Vehicle v;
  v.instance_id = index;
  v.id = absl::StrCat("vehicle_", index);
  v.category = rng.Unit() < 0.3 ? "van" : "car";
  if (v.category == "van") {
    v.size = {rng.Uniform(5.0, 5.6), rng.Uniform(1.95, 2.1), rng.Uniform(2.1, 2.4)};
  } else {
    v.size = {rng.Uniform(4.1, 4.8), rng.Uniform(1.75, 1.9), rng.Uniform(1.42, 1.6)};
  }
  v.albedo = PaintColour(rng);
  v.texture_seed = rng.NextU32();
  v.parts = VehicleParts(v.category, v.size);
  v.start_position = {ground_position.x, ground_position.y, v.size.z / 2};
  v.start_heading = heading;
  v.speed = speed;
  v.yaw_rate = yaw_rate;
  return v;
}

// Returns true if two vehicles' footprints come within 0.3 m of each other
// at some time in [0, kVehicleCheckSeconds].
bool AnyVehiclesCollide(const std::vector<Vehicle>& vehicles) {
  for (double t = 0; t <= kVehicleCheckSeconds + 1e-9; t += 0.05) {
    for (size_t i = 0; i < vehicles.size(); ++i) {
      for (size_t j = i + 1; j < vehicles.size(); ++j) {
        if (FootprintsOverlap(vehicles[i].BoxToWorldAt(t), vehicles[i].size,
                              vehicles[j].BoxToWorldAt(t), vehicles[j].size, 0.3)) {
          return true;
        }
      }
    }
  }
  return false;
}

}  // namespace

bool FootprintsOverlap(const Rigid& a, const Vec3& size_a, const Rigid& b, const Vec3& size_b,
                       double margin) {
  // Separating axis test of two rectangles in the ground plane: the axes are
  // the boxes' own x and y axes.
  const Vec3 axes[4] = {a.rotation.Col(0), a.rotation.Col(1), b.rotation.Col(0), b.rotation.Col(1)};
  const Vec3 d = b.translation - a.translation;
  for (const Vec3& axis_3d : axes) {
    const Vec3 axis = Normalized(Vec3{axis_3d.x, axis_3d.y, 0});
    auto radius = [&](const Rigid& box, const Vec3& size) {
      return 0.5 * size.x * std::abs(Dot(box.rotation.Col(0), axis)) +
             0.5 * size.y * std::abs(Dot(box.rotation.Col(1), axis));
    };
    if (std::abs(Dot(d, axis)) > radius(a, size_a) + radius(b, size_b) + margin) return false;
  }
  return true;
}

absl::Status ValidateSynthOptions(const SynthOptions& options) {
  if (options.seed >= (uint64_t{1} << 53)) {
    return absl::InvalidArgumentError(
        absl::StrCat("seed: must be in [0, 2^53), got ", options.seed));
  }
  if (options.num_cameras < 1 || options.num_cameras > 8) {
    return OutOfRange("cameras", "[1, 8]", options.num_cameras);
  }
  if (options.num_frames < 1 || options.num_frames > 600) {
    return OutOfRange("frames", "[1, 600]", options.num_frames);
  }
  if (options.width < 16 || options.width > 8192) {
    return OutOfRange("width", "[16, 8192]", options.width);
  }
  if (options.height < 16 || options.height > 8192) {
    return OutOfRange("height", "[16, 8192]", options.height);
  }
  if (options.antialias < 1 || options.antialias > 4) {
    return OutOfRange("antialias", "[1, 4]", options.antialias);
  }
  return absl::OkStatus();
}

std::vector<double> SynthFThetaPolynomial(int width) {
  constexpr double kCubic = -0.05;
  const double side = kFThetaHalfFovDeg * kDeg;
  const double f = (width / 2.0) / (side + kCubic * side * side * side);
  return {0.0, f, 0.0, kCubic * f, 0.0, 0.0};
}

bool IsContextTimestamp(int64_t timestamp_us) {
  return std::find(std::begin(kContextTimestampsUs), std::end(kContextTimestampsUs),
                   timestamp_us) != std::end(kContextTimestampsUs);
}

Mat3 YawRotation(double yaw) {
  const double c = std::cos(yaw), s = std::sin(yaw);
  Mat3 r;
  r.m = {{{c, -s, 0}, {s, c, 0}, {0, 0, 1}}};
  return r;
}

Mat3 EgoFromOpenCvCamera(double yaw, double pitch) {
  const Vec3 forward{std::cos(pitch) * std::cos(yaw), std::cos(pitch) * std::sin(yaw),
                     std::sin(pitch)};
  const Vec3 right{std::sin(yaw), -std::cos(yaw), 0};
  const Vec3 down = Cross(forward, right);
  return Mat3::FromColumns(right, down, forward);
}

Rigid Vehicle::BoxToWorldAt(double t) const {
  const double heading = start_heading + yaw_rate * t;
  Vec3 p = start_position;
  if (std::abs(yaw_rate) < 1e-9) {
    p.x += speed * t * std::cos(start_heading);
    p.y += speed * t * std::sin(start_heading);
  } else {
    const double r = speed / yaw_rate;
    p.x += r * (std::sin(heading) - std::sin(start_heading));
    p.y -= r * (std::cos(heading) - std::cos(start_heading));
  }
  return {YawRotation(heading), p};
}

Rigid SynthScene::EgoPoseAt(double t) const {
  return {Mat3::Identity(), {ego_start_x + ego_speed * t, ego_lane_y, 0.0}};
}

Rigid SynthScene::WorldFromCamera(int index, double t) const {
  const RigCamera& cam = cameras[index];
  const Rigid ego_from_camera{EgoFromOpenCvCamera(cam.yaw, cam.pitch), cam.position};
  return EgoPoseAt(t) * ego_from_camera;
}

Rigid SynthScene::WorldFromLidar(double t) const {
  return EgoPoseAt(t) * Rigid{Mat3::Identity(), lidar_position};
}

std::vector<int64_t> SynthScene::FrameTimestampsUs() const {
  std::vector<int64_t> out;
  const int64_t period_us = static_cast<int64_t>(std::llround(1e6 / kFrameRateHz));
  for (int i = 0; i < options.num_frames; ++i) out.push_back(i * period_us);
  return out;
}

int SynthScene::FindCamera(const std::string& id) const {
  for (size_t i = 0; i < cameras.size(); ++i) {
    if (cameras[i].id == id) return static_cast<int>(i);
  }
  return -1;
}

absl::StatusOr<SynthScene> GenerateSynthScene(const SynthOptions& options) {
  if (absl::Status status = ValidateSynthOptions(options); !status.ok()) return status;
  SynthScene scene;
  scene.options = options;
  SynthRng rng(options.seed);
  RoadLayout& road = scene.road;
  road.junction_x = 45.0 + rng.Uniform(-5.0, 5.0);
  road.pavement_width = rng.Uniform(3.0, 4.0);

  // Pavements: four quadrant slabs around the road and the cross street.
  const double jx = road.junction_x, jw = road.junction_half_width;
  const Vec3 paving{0.62, 0.60, 0.57};
  for (int side : {-1, 1}) {
    AddBox(scene.boxes, {kStreetBeginX - 10, side * road.half_width, 0},
           {jx - jw, side * 175.0, road.kerb_height}, StaticKind::kPavement, rng.NextU32(), paving);
    AddBox(scene.boxes, {jx + jw, side * road.half_width, 0},
           {kStreetEndX + 30, side * 175.0, road.kerb_height}, StaticKind::kPavement, rng.NextU32(),
           paving);
  }

  // Buildings along the road, along the cross street, and closing both ends.
  const double facade = road.half_width + road.pavement_width;
  const double corner = jx - jw - road.pavement_width;  // Facade x before the junction.
  for (int side : {-1, 1}) {
    AddBuildingRowAlongX(rng, side, kStreetBeginX, corner, facade, scene.boxes);
    AddBuildingRowAlongX(rng, side, jx + jw + road.pavement_width, kStreetEndX, facade,
                         scene.boxes);
  }
  AddBuildingRowAlongY(rng, -1, corner, 30.0, 150.0, scene.boxes);
  AddBuildingRowAlongY(rng, +1, jx + jw + road.pavement_width, 30.0, 150.0, scene.boxes);
  for (double y = -70.0; y < 70.0; y += 20.0) {
    AddBox(scene.boxes, {kStreetEndX + 2, y, 0}, {kStreetEndX + 18, y + 20, rng.Uniform(10, 26)},
           StaticKind::kBuilding, rng.NextU32(), FacadeColour(rng));
  }
  for (int side : {-1, 1}) {
    AddBox(scene.boxes, {jx - 40, side * 152.0, 0}, {jx + 40, side * 168.0, rng.Uniform(10, 26)},
           StaticKind::kBuilding, rng.NextU32(), FacadeColour(rng));
  }
  AddPoles(rng, road, scene.boxes);

  // The ego drives along +x in the right lane.
  scene.ego_lane_y = -road.lane_width / 2;
  scene.ego_speed = rng.Uniform(7.0, 9.0);
  scene.ego_start_x = 0;

  // Vehicles: one ahead in the ego lane, one oncoming, one crossing at the
  // junction, one overtaking on the right; redrawn until their footprints
  // stay apart over the first kVehicleCheckSeconds.
  const double lane = road.lane_width;
  for (int attempt = 0; attempt < 100; ++attempt) {
    scene.vehicles.clear();
    scene.vehicles.push_back(MakeVehicle(rng, 1, {rng.Uniform(14.0, 18.0), -lane / 2, 0}, 0.0,
                                         scene.ego_speed - rng.Uniform(1.0, 2.0), 0.0));
    scene.vehicles.push_back(MakeVehicle(rng, 2, {rng.Uniform(50.0, 60.0), lane / 2, 0}, kPi,
                                         rng.Uniform(8.0, 10.0), 0.0));
    scene.vehicles.push_back(MakeVehicle(rng, 3, {jx + lane / 2, -rng.Uniform(12.0, 14.0), 0},
                                         kPi / 2, rng.Uniform(5.0, 7.0), rng.Uniform(-0.06, 0.06)));
    scene.vehicles.push_back(MakeVehicle(rng, 4, {rng.Uniform(3.0, 6.0), -1.5 * lane, 0}, 0.0,
                                         scene.ego_speed + rng.Uniform(2.0, 4.0), 0.0));
    if (!AnyVehiclesCollide(scene.vehicles)) break;
  }

  // Cameras: front-facing, spread in yaw from left to right.
  const int n = options.num_cameras;
  const double spacing = std::min(kCameraYawSpacingDeg, 360.0 / n) * kDeg;
  const double fx = (options.width / 2.0) / std::tan(kHorizontalFovDeg / 2 * kDeg);
  for (int i = 0; i < n; ++i) {
    RigCamera cam;
    if (n == 3) {
      cam.id = i == 0 ? "cam_left" : (i == 1 ? "cam_front" : "cam_right");
    } else if (n == 1) {
      cam.id = "cam_front";
    } else {
      cam.id = absl::StrCat("cam_", i);
    }
    cam.yaw = spacing * ((n - 1) / 2.0 - i);
    cam.pitch = kCameraPitchDeg * kDeg;
    cam.position = {1.6, 0.3 * std::sin(cam.yaw), 1.55};
    cam.model = CameraModel(options.width, options.height, fx, fx, options.width / 2.0,
                            options.height / 2.0);
    if (options.lens == SynthLens::kFTheta) {
      cam.model.SetFTheta(SynthFThetaPolynomial(options.width));
    }
    scene.cameras.push_back(cam);
  }
  scene.lidar_position = {0.2, 0.0, 1.9};
  return scene;
}

}  // namespace pf
