// Standard 3D Gaussian Splatting PLY files, so scenes move between our tools
// and common splat viewers.
//
// The layout is the one the reference 3DGS code writes: one `vertex` element
// with float properties x, y, z, nx, ny, nz, f_dc_0..2, f_rest_0..M-1,
// opacity, scale_0..2, rot_0..3, where
//   - f_rest is channel-major: all of R's higher-order coefficients, then G's,
//     then B's (M = 3 * ((degree + 1)^2 - 1));
//   - opacity is the pre-sigmoid logit, scale_* the natural log of the
//     standard deviations, rot_* a quaternion (w, x, y, z), not necessarily
//     normalised.
//
// Export:
//   - Colour: a scene with SH writes its coefficients; one without writes
//     f_dc from the first three feature channels, inverting the degree-0
//     evaluation rgb = 0.5 + C0 * f_dc (C0 = 0.28209479177387814), so viewers
//     show the right colours. f_dc holds the sRGB-encoded colour, which is
//     what 3DGS tools train and viewers display: a linear scene's colours are
//     encoded first (GaussianScene::colour_encoding). pf_feature_* and
//     pf_colour_gradient_* stay in the scene's encoding.
//   - Instances: PLY has no scene graph, so each instance's Gaussians are
//     written in world space, placed by the instance's box pose at
//     PlyExportOptions::timestamp_us (default: the scene's time_origin_us).
//     Every Gaussian is written as background.
//   - Our extras, which viewers ignore: properties pf_feature_0..N_c-1 when
//     the features cannot be recovered from f_dc (SH present, or N_c != 3),
//     pf_time and pf_lifespan when any lifespan is finite,
//     pf_colour_gradient_0..5 when the scene has colour gradients (all six
//     are needed on import), and a header line `comment pointforward
//     time_origin_us=T sh_degree=D low_pass=S colour_encoding=srgb|linear` so
//     that our own import restores those fields (a PLY without it gets the
//     3DGS low-pass, 0.3, which is what other tools trained it under, and sRGB
//     colours).
//
// Import reads binary (little- or big-endian) and ASCII PLY, in any property
// order and with any extra properties or elements (list properties are
// skipped in elements other than `vertex`). x, y, z, opacity, scale_0..2
// and rot_0..3 are required; colour comes from f_dc_0..2 (+ f_rest_*), else
// from red, green, blue (8-bit or float). Without pf_feature_* the features
// are the 3 channels 0.5 + C0 * f_dc, sRGB-encoded, decoded to linear when our
// comment says the scene was linear.
#ifndef POINTFORWARD_ENGINE_RENDER_PLY_IO_H_
#define POINTFORWARD_ENGINE_RENDER_PLY_IO_H_

#include <cstdint>
#include <optional>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "engine/render/gaussian_scene.h"

namespace pf {

// The degree-0 SH basis constant: rgb = 0.5 + kShC0 * f_dc.
inline constexpr double kShC0 = 0.28209479177387814;

struct PlyExportOptions {
  // Scene time at which instance Gaussians are placed in the world; unset
  // means scene.time_origin_us.
  std::optional<int64_t> timestamp_us;
};

// Returns the bytes of a binary little-endian 3DGS PLY of `scene`.
// INVALID_ARGUMENT if the scene is inconsistent (see ValidateScene).
absl::StatusOr<std::string> EncodePly(const GaussianScene& scene,
                                      const PlyExportOptions& options = {});

// Writes EncodePly(scene, options) to `path` atomically.
absl::Status ExportPly(const GaussianScene& scene, const std::string& path,
                       const PlyExportOptions& options = {});

// Parses PLY bytes; `source` names them in errors. INVALID_ARGUMENT for a
// malformed header (naming the line), a missing required property, an f_rest
// count that is no SH degree, or a body shorter than the header says (with
// both sizes); UNIMPLEMENTED for list properties where they cannot be skipped.
absl::StatusOr<GaussianScene> DecodePly(const std::string& bytes, const std::string& source);

// Reads and decodes the PLY file at `path`; NOT_FOUND when missing.
absl::StatusOr<GaussianScene> ImportPly(const std::string& path);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RENDER_PLY_IO_H_
