// Procedural textures and lighting of the synthetic scene. Every texture is
// a pure function of the surface point and the primitive's seed, with sharp
// edges and fine detail (lane markings, window frames, brick joints, 5x7
// glyphs on signs and number plates) so that blur or ghosting in a
// reconstruction costs PSNR. Lighting is a fixed sun plus ambient, without
// shadows, so shading depends only on the surface normal.
#ifndef POINTFORWARD_ENGINE_SYNTH_SYNTH_SHADING_H_
#define POINTFORWARD_ENGINE_SYNTH_SYNTH_SHADING_H_

#include "common/geometry.h"
#include "engine/synth/synth_scene.h"

namespace pf {

// A face of an axis-aligned box: the axis of its normal (0 x, 1 y, 2 z) and
// the normal's sign.
struct BoxFace {
  int axis = 2;
  int sign = 1;
  Vec3 Normal() const {
    Vec3 n;
    n[axis] = sign;
    return n;
  }
};

// Returns the sky colour seen along unit direction `dir` (world frame): a
// horizon-to-zenith gradient with clouds.
Vec3 SkyColour(const Vec3& dir);

// Returns the albedo of the road surface (z = 0) at world (x, y): asphalt
// with grain, lane lines, crossings and stop lines.
Vec3 GroundAlbedo(const RoadLayout& road, double x, double y);

// Returns the albedo of `box` at world point `p` on `face`.
Vec3 StaticAlbedo(const StaticBox& box, const Vec3& p, const BoxFace& face);

// Returns the albedo of `part` of `vehicle` at box-frame point `p` on `face`
// (box-frame axes).
Vec3 VehicleAlbedo(const Vehicle& vehicle, const VehiclePart& part, const Vec3& p,
                   const BoxFace& face);

// Returns the lit colour of a surface of `albedo` with world normal `normal`.
Vec3 Shade(const Vec3& albedo, const Vec3& normal);

// Returns the Rec. 709 luminance of `c`.
inline double Luminance(const Vec3& c) { return 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z; }

// Returns true if the 5x7 glyph `glyph` (any integer; taken modulo the font
// size) has ink at column `col` in [0, 5) and row `row` in [0, 7) (row 0 at
// the top).
bool GlyphInk(uint32_t glyph, int col, int row);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_SYNTH_SYNTH_SHADING_H_
