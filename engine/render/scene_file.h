// Our Gaussian scene file: a versioned, checksummed binary that loads with one
// read per array (docs/SCENE_FORMAT.md has the byte layout).
//
//   RETURN_IF_ERROR(SaveScene(scene, "/data/scenes/abc.pfscene"));
//   ASSIGN_OR_RETURN(GaussianScene scene, LoadScene("/data/scenes/abc.pfscene"));
//
// The file is little-endian; every array of GaussianScene is stored
// contiguously in its in-memory layout, followed by a SHA-256 of all bytes
// before it. Files are written atomically (temporary name, then rename).
#ifndef POINTFORWARD_ENGINE_RENDER_SCENE_FILE_H_
#define POINTFORWARD_ENGINE_RENDER_SCENE_FILE_H_

#include <cstdint>
#include <map>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "engine/render/gaussian_scene.h"

namespace pf {

// The first 8 bytes of every scene file.
inline constexpr char kSceneFileMagic[8] = {'P', 'F', 'S', 'C', 'E', 'N', 'E', '\0'};
// The version this code writes, and the oldest it reads. Version 2 added the
// scene's low-pass (GaussianScene::low_pass); version 1 files read as 0.3.
// Version 3 added colour gradients (GaussianScene::colour_gradients): a flag
// in the header after the low-pass, the array after the owners; older files
// read with flat colours. Version 4 added the colours' encoding
// (GaussianScene::colour_encoding, 0 sRGB, 1 linear) after that flag; older
// files read as sRGB. Version 5 added the order band after the encoding
// (older files: 0). Version 6 added the LiDAR intensity channel after the
// order band (int32, -1 none; older files: -1). Version 7 added the ego
// layers (GaussianScene::ego_layers): their ids, sizes and body pixel counts
// after the metadata, their masks and colours after the arrays (older files:
// none). Version 8 added the fade span (GaussianScene::fade_span, two
// float32 after the LiDAR intensity channel; older files: unbounded).
// Version 9 added the ego layers' frames (EgoLayer::frames): per layer their
// count and times after its body pixel count, their colours after its own
// (older files: none, the mean colour at every time). Version 10 added the
// render blur (GaussianScene::render_blur, a float32 after the fade span;
// older files: 0). Version 11 added its growth and anchors after it
// (GaussianScene::render_blur_growth, a float32; the anchor count, uint32;
// per anchor its centre and axis, six float32; older files: 0, none).
inline constexpr uint32_t kSceneFileVersion = 11;
inline constexpr uint32_t kOldestSceneFileVersion = 1;

// A scene as stored: the Gaussians, free-form metadata (e.g. "model",
// "source_clip") and the file's SHA-256 checksum (hex), which identifies
// the content.
struct SceneFile {
  uint32_t version = kSceneFileVersion;  // The version the file was written in.
  GaussianScene scene;
  std::map<std::string, std::string> metadata;
  std::string checksum_hex;
};

// Returns INVALID_ARGUMENT naming the array or field when `scene` is not
// self-consistent: array sizes that do not match size(), num_channels outside
// [1, 256], sh_degree outside [-1, 3], low_pass outside [0, kMaxLowPass],
// a render blur or its growth out of range, a blur anchor that is not finite
// or whose axis is not of unit length,
// a LiDAR intensity channel other than -1 or one of the channels, an ego
// layer that fails CheckEgoLayer or repeats a camera,
// colour gradients with SH or non-finite,
// an owner beyond the instances, an
// instance without boxes or with unsorted boxes, non-finite values in the
// geometry arrays.
absl::Status ValidateScene(const GaussianScene& scene);

// Writes `scene` (validated first) and `metadata` to `path` atomically,
// creating parent directories.
absl::Status SaveScene(const GaussianScene& scene, const std::string& path,
                       const std::map<std::string, std::string>& metadata = {});

// Reads a scene file. NOT_FOUND when `path` is missing; INVALID_ARGUMENT
// naming the path for a wrong magic, an unsupported version, a header whose
// counts are out of range, a file shorter or longer than its header says
// (both sizes named), a checksum mismatch, or a scene that fails
// ValidateScene. Sizes are checked against the file size before anything is
// allocated.
absl::StatusOr<SceneFile> ReadSceneFile(const std::string& path);

// Returns ReadSceneFile(path)->scene.
absl::StatusOr<GaussianScene> LoadScene(const std::string& path);

// Returns true if the file at `path` starts with kSceneFileMagic.
bool LooksLikeSceneFile(const std::string& path);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RENDER_SCENE_FILE_H_
