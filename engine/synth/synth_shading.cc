// Procedural textures and lighting of the synthetic scene (see
// synth_shading.h).
#include "engine/synth/synth_shading.h"

#include <algorithm>
#include <cmath>

#include "engine/synth/synth_random.h"

namespace pf {
namespace {

// A 5x7 font: digits and capitals; each row is 5 bits, bit 4 leftmost.
constexpr uint8_t kFont[][7] = {
    {0x0E, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0E}, {0x04, 0x0C, 0x04, 0x04, 0x04, 0x04, 0x0E},
    {0x0E, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1F}, {0x1F, 0x02, 0x04, 0x02, 0x01, 0x11, 0x0E},
    {0x02, 0x06, 0x0A, 0x12, 0x1F, 0x02, 0x02}, {0x1F, 0x10, 0x1E, 0x01, 0x01, 0x11, 0x0E},
    {0x06, 0x08, 0x10, 0x1E, 0x11, 0x11, 0x0E}, {0x1F, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08},
    {0x0E, 0x11, 0x11, 0x0E, 0x11, 0x11, 0x0E}, {0x0E, 0x11, 0x11, 0x0F, 0x01, 0x02, 0x0C},
    {0x0E, 0x11, 0x11, 0x1F, 0x11, 0x11, 0x11}, {0x1E, 0x11, 0x11, 0x1E, 0x11, 0x11, 0x1E},
    {0x0E, 0x11, 0x10, 0x10, 0x10, 0x11, 0x0E}, {0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x1F},
    {0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x10}, {0x11, 0x11, 0x11, 0x1F, 0x11, 0x11, 0x11},
    {0x11, 0x12, 0x14, 0x18, 0x14, 0x12, 0x11}, {0x10, 0x10, 0x10, 0x10, 0x10, 0x10, 0x1F},
    {0x11, 0x1B, 0x15, 0x15, 0x11, 0x11, 0x11}, {0x11, 0x11, 0x19, 0x15, 0x13, 0x11, 0x11},
    {0x1E, 0x11, 0x11, 0x1E, 0x10, 0x10, 0x10}, {0x1E, 0x11, 0x11, 0x1E, 0x14, 0x12, 0x11},
    {0x0F, 0x10, 0x10, 0x0E, 0x01, 0x01, 0x1E}, {0x1F, 0x04, 0x04, 0x04, 0x04, 0x04, 0x04},
    {0x11, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0E}, {0x11, 0x11, 0x0A, 0x04, 0x0A, 0x11, 0x11},
    {0x11, 0x11, 0x0A, 0x04, 0x04, 0x04, 0x04}, {0x1F, 0x01, 0x02, 0x04, 0x08, 0x10, 0x1F},
};
constexpr uint32_t kFontSize = sizeof(kFont) / sizeof(kFont[0]);

const Vec3 kWhite{0.93, 0.93, 0.91};
const Vec3 kYellow{0.92, 0.74, 0.12};
const Vec3 kGlass{0.09, 0.11, 0.15};

Vec3 Grey(double g) { return {g, g, g}; }
Vec3 Mix(const Vec3& a, const Vec3& b, double t) { return a * (1 - t) + b * t; }
double Frac(double x) { return x - std::floor(x); }
double SmoothStep(double a, double b, double x) {
  const double t = std::clamp((x - a) / (b - a), 0.0, 1.0);
  return t * t * (3 - 2 * t);
}

// Returns true if a line of `n_chars` glyphs filling [0, width] x [0, height]
// (v up) has ink at (u, v). Some characters are spaces.
bool TextInk(double u, double v, double width, double height, int n_chars, uint32_t seed) {
  if (u < 0 || v < 0 || u >= width || v >= height) return false;
  const double cell = width / n_chars;
  const int index = static_cast<int>(u / cell);
  const uint32_t h = Hash3(seed, static_cast<uint32_t>(index), 77);
  if (h % 10 == 0) return false;                                    // A space.
  const int col = static_cast<int>(Frac(u / cell) * 6);             // Column 5 is spacing.
  const int row = static_cast<int>((height - v) / height * 9) - 1;  // Rows -1, 7 margins.
  return col < 5 && GlyphInk(h >> 8, col, row);
}

// Returns a sign or band colour chosen by `h`.
Vec3 SignColour(uint32_t h) {
  static constexpr double kColours[][3] = {
      {0.05, 0.25, 0.12}, {0.55, 0.06, 0.06}, {0.06, 0.12, 0.40},
      {0.08, 0.08, 0.08}, {0.85, 0.55, 0.05}, {0.35, 0.05, 0.35},
  };
  const auto& c = kColours[h % 6];
  return {c[0], c[1], c[2]};
}

// Returns the facade texture at horizontal position `u` (metres from the
// facade's start) and height `v`, for a building of `height`.
Vec3 FacadeAlbedo(const Vec3& base, uint32_t seed, double u, double v, double height) {
  const double floor_h = 2.8 + 0.8 * HashUnit(seed, 1);
  const double bay = 2.2 + 1.2 * HashUnit(seed, 2);
  const double window_w = bay * (0.42 + 0.25 * HashUnit(seed, 3));
  const double window_h = floor_h * (0.45 + 0.2 * HashUnit(seed, 4));
  const bool brick = HashUnit(seed, 5) < 0.5;

  // Wall: tone noise, brick courses or panel joints.
  Vec3 wall = base * (0.9 + 0.18 * ValueNoise(u * 1.5, v * 1.5, seed));
  if (brick) {
    const double course = v / 0.24;
    const double shift = (static_cast<int64_t>(std::floor(course)) & 1) ? 0.25 : 0.0;
    if (Frac(course) < 0.14 || Frac(u / 0.5 + shift) < 0.07) wall = wall * 0.78;
  } else if (Frac(u / 1.2) < 0.02 || Frac(v / 1.5) < 0.02) {
    wall = wall * 0.82;
  }
  if (v > height - 0.6) return wall * 0.85;  // Parapet.

  const int bay_index = static_cast<int>(std::floor(u / bay));
  const double bu = u - bay_index * bay;  // Position inside the bay.
  if (v < floor_h) {
    // Ground floor: a shop sign with lettering above a shop window.
    const double sign_lo = floor_h - 0.8, sign_hi = floor_h - 0.2;
    if (v >= sign_lo && v < sign_hi) {
      const uint32_t shop = Hash3(seed, static_cast<uint32_t>(bay_index / 3), 9);
      const double shop_u = u - (bay_index / 3) * 3 * bay;
      const bool ink = TextInk(shop_u - 0.3, v - sign_lo - 0.06, 3 * bay - 0.6, 0.48,
                               static_cast<int>((3 * bay - 0.6) / 0.34), shop);
      return ink ? (shop % 6 == 4 ? Grey(0.05) : kWhite) : SignColour(shop);
    }
    if (v > 0.35 && v < sign_lo - 0.15 && bu > 0.15 && bu < bay - 0.15) {
      if (bu < 0.22 || bu > bay - 0.22 || v < 0.42 || v > sign_lo - 0.22) return Grey(0.2);
      return Mix(kGlass, Grey(0.35), 0.4 * (v / floor_h));
    }
    return wall;
  }
  // Upper floors: framed windows with mullions, some lit.
  const int floor_index = static_cast<int>(std::floor(v / floor_h));
  const double fv = v - floor_index * floor_h;
  const double wu0 = (bay - window_w) / 2, wv0 = 0.85;
  if (bu >= wu0 && bu < wu0 + window_w && fv >= wv0 && fv < wv0 + window_h) {
    const double lu = bu - wu0, lv = fv - wv0;
    const double frame = 0.07;
    if (lu < frame || lu > window_w - frame || lv < frame || lv > window_h - frame ||
        std::abs(lu - window_w / 2) < 0.03 || std::abs(lv - 0.62 * window_h) < 0.03) {
      return Grey(0.86);
    }
    const double pane =
        HashUnit(seed, static_cast<uint32_t>(bay_index), static_cast<uint32_t>(floor_index));
    if (pane < 0.15) return Vec3{0.85, 0.72, 0.42};  // Lit.
    return Mix(kGlass, Vec3{0.45, 0.55, 0.7}, 0.5 * lv / window_h * (0.5 + pane));
  }
  if (bu >= wu0 - 0.05 && bu < wu0 + window_w + 0.05 && fv >= wv0 - 0.12 && fv < wv0) {
    return Grey(0.78);  // Sill.
  }
  if (fv < 0.12) return wall * 0.8;  // Floor band.
  return wall;
}

}  // namespace

bool GlyphInk(uint32_t glyph, int col, int row) {
  if (col < 0 || col >= 5 || row < 0 || row >= 7) return false;
  return (kFont[glyph % kFontSize][row] >> (4 - col)) & 1;
}

Vec3 SkyColour(const Vec3& dir) {
  const double up = std::clamp(dir.z, 0.0, 1.0);
  Vec3 sky = Mix(Vec3{0.80, 0.86, 0.93}, Vec3{0.28, 0.48, 0.84}, std::sqrt(up));
  if (up > 0.01) {
    // Clouds on a plane above: value noise of the ray's hit point.
    const double sx = dir.x / dir.z, sy = dir.y / dir.z;
    const double n =
        0.65 * ValueNoise(sx * 1.2, sy * 1.2, 31) + 0.35 * ValueNoise(sx * 5, sy * 5, 32);
    const double cloud = SmoothStep(0.5, 0.72, n) * SmoothStep(0.01, 0.15, up);
    sky = Mix(sky, Vec3{0.96, 0.96, 0.97}, 0.85 * cloud);
  }
  return sky;
}

Vec3 GroundAlbedo(const RoadLayout& road, double x, double y) {
  const double grain = HashUnit(Cell(x * 20), Cell(y * 20), 11);
  const double g = 0.22 + 0.08 * ValueNoise(x * 0.4, y * 0.4, 12) + 0.07 * (grain - 0.5);
  const Vec3 asphalt{g, g, g * 1.04};
  const double ay = std::abs(y);
  const double dx = x - road.junction_x;
  const double adx = std::abs(dx);
  const double hw = road.half_width, jw = road.junction_half_width, lane = road.lane_width;
  const bool in_main = ay < hw;
  const bool in_cross = adx < jw;
  if (in_main && !in_cross) {
    if (ay > 0.06 && ay < 0.18) return kYellow;  // Double centre line.
    if (std::abs(ay - lane) < 0.07 && Frac((x + 1000) / 9.0) < 1.0 / 3) return kWhite;  // Dashes.
    if (std::abs(ay - (hw - 0.3)) < 0.08) return kWhite;                         // Edge lines.
    if (adx > jw + 1 && adx < jw + 4 && Frac(y + 100.25) < 0.5) return kWhite;   // Zebra.
    if (adx > jw + 4.6 && adx < jw + 5.0 && (dx < 0) == (y < 0)) return kWhite;  // Stop line.
    // Lane lettering ("text on the road") in the ego lane before the junction.
    const double text_begin = road.junction_x - jw - 14.0;
    if (y < -0.6 && y > -lane + 0.6 && x > text_begin && x < text_begin + 5.0) {
      // Characters run along -y, read from the ego: u across, v along x.
      if (TextInk(-y - 0.6, x - text_begin, lane - 1.2, 5.0, 4, 5)) return kWhite;
    }
    return asphalt;
  }
  if (in_cross && !in_main) {
    if (adx > 0.06 && adx < 0.18) return kYellow;
    if (std::abs(adx - lane) < 0.07 && Frac((ay + 1000) / 9.0) < 1.0 / 3) return kWhite;
    if (ay > hw + 1 && ay < hw + 4 && Frac(dx + 100.25) < 0.5) return kWhite;
  }
  return asphalt;
}

Vec3 StaticAlbedo(const StaticBox& box, const Vec3& p, const BoxFace& face) {
  const uint32_t seed = box.texture_seed;
  switch (box.kind) {
    case StaticKind::kPavement: {
      if (face.axis == 2) {
        // Paving slabs of 0.6 m with joints and a tone per slab.
        const double sx = p.x / 0.6, sy = p.y / 0.6;
        if (Frac(sx) < 0.04 || Frac(sy) < 0.04) return box.albedo * 0.62;
        const double tone = 0.88 + 0.2 * HashUnit(Cell(sx), Cell(sy), seed);
        const double grain = 0.06 * (HashUnit(Cell(p.x * 40), Cell(p.y * 40), seed + 1) - 0.5);
        return box.albedo * (tone + grain);
      }
      // Kerb stones: light granite with joints every metre.
      const double u = face.axis == 0 ? p.y : p.x;
      if (Frac(u) < 0.03) return Grey(0.35);
      return Grey(0.74 + 0.08 * (HashUnit(Cell(u * 30), Cell(p.z * 30), seed) - 0.5));
    }
    case StaticKind::kBuilding: {
      if (face.axis == 2) {
        return Grey(0.3 + 0.05 * HashUnit(Cell(p.x * 10), Cell(p.y * 10), seed));
      }
      // u runs left to right as seen from outside the face, so that
      // lettering reads the right way round.
      double u;
      if (face.axis == 1) {
        u = face.sign < 0 ? p.x - box.lo.x : box.hi.x - p.x;
      } else {
        u = face.sign > 0 ? p.y - box.lo.y : box.hi.y - p.y;
      }
      return FacadeAlbedo(box.albedo, seed, u, p.z, box.hi.z);
    }
    case StaticKind::kPole: {
      // Black and white bands near eye level, metal elsewhere.
      if (p.z > 1.0 && p.z < 1.6) return Frac(p.z / 0.2) < 0.5 ? Grey(0.08) : kWhite;
      return box.albedo * (0.9 + 0.2 * HashUnit(Cell(p.z * 8), seed));
    }
  }
  return box.albedo;
}

Vec3 VehicleAlbedo(const Vehicle& vehicle, const VehiclePart& part, const Vec3& p,
                   const BoxFace& face) {
  const Vec3& paint = vehicle.albedo;
  const double half_w = vehicle.size.y / 2;
  switch (part.kind) {
    case VehiclePartKind::kBody: {
      const double z_mid = 0.5 * (part.lo.z + part.hi.z);
      const double zr = (p.z - part.lo.z) / (part.hi.z - part.lo.z);  // 0 bottom, 1 top.
      if (face.axis == 2) return paint;
      if (face.axis == 1) {
        // Sides: door seams, a trim line, handles, a darker sill.
        for (double seam : {-0.12 * vehicle.size.x, 0.16 * vehicle.size.x}) {
          if (std::abs(p.x - seam) < 0.015) return paint * 0.35;
          if (p.x > seam - 0.35 && p.x < seam - 0.17 && std::abs(zr - 0.72) < 0.05) {
            return Grey(0.15);
          }
        }
        if (std::abs(p.z - z_mid) < 0.025) return Grey(0.12);
        if (zr < 0.12) return Grey(0.1);
        return paint;
      }
      const double ay = std::abs(p.y);
      // Number plate with lettering, front and rear.
      const double plate_lo = z_mid - 0.08;
      if (ay < 0.26 && p.z >= plate_lo && p.z < plate_lo + 0.12) {
        const bool ink = TextInk(p.y * face.sign + 0.26 - 0.02, p.z - plate_lo - 0.01, 0.48, 0.10,
                                 6, vehicle.texture_seed);
        return ink ? Grey(0.05) : kWhite;
      }
      if (face.sign > 0) {  // Front: headlights and grille.
        if (ay > half_w - 0.5 && ay < half_w - 0.08 && zr > 0.55 && zr < 0.85) {
          return Vec3{0.97, 0.95, 0.85};
        }
        if (ay < half_w - 0.6 && zr > 0.55 && zr < 0.85) {
          return Frac(p.z / 0.05) < 0.5 ? Grey(0.05) : Grey(0.3);
        }
        return paint;
      }
      if (ay > half_w - 0.42 && ay < half_w - 0.06 && zr > 0.55 && zr < 0.85) {
        return Vec3{0.75, 0.04, 0.04};  // Tail lights.
      }
      return paint;
    }
    case VehiclePartKind::kCabin: {
      if (face.axis == 2) return paint;
      const double pillar = 0.09;
      const bool edge_z = p.z < part.lo.z + 0.05 || p.z > part.hi.z - 0.05;
      const double u = face.axis == 1 ? p.x : p.y;
      const double u_lo = face.axis == 1 ? part.lo.x : part.lo.y;
      const double u_hi = face.axis == 1 ? part.hi.x : part.hi.y;
      bool frame = edge_z || u < u_lo + pillar || u > u_hi - pillar;
      if (face.axis == 1 && std::abs(u - 0.5 * (u_lo + u_hi)) < 0.05) frame = true;  // B pillar.
      if (frame) return paint * 0.8;
      const double zr = (p.z - part.lo.z) / (part.hi.z - part.lo.z);
      return Mix(kGlass, Vec3{0.4, 0.48, 0.6}, 0.45 * zr);
    }
    case VehiclePartKind::kWheel: {
      if (face.axis == 1) {
        const double cx = 0.5 * (part.lo.x + part.hi.x), cz = 0.5 * (part.lo.z + part.hi.z);
        const double r = std::hypot(p.x - cx, p.z - cz);
        if (r < 0.17) {
          const double angle = std::atan2(p.z - cz, p.x - cx);
          return Frac(angle / (2 * 3.14159265358979) * 5) < 0.3 ? Grey(0.25) : Grey(0.68);
        }
      }
      return Grey(0.05);
    }
  }
  return paint;
}

Vec3 Shade(const Vec3& albedo, const Vec3& normal) {
  static const Vec3 kSun = Normalized(Vec3{0.35, 0.55, 0.75});
  const double light = 0.55 + 0.5 * std::max(0.0, Dot(normal, kSun));
  return albedo * light;
}

}  // namespace pf
