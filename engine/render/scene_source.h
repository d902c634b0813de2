// Opening a scene the user names on the command line: our scene file
// (recognised by its magic) or a 3DGS PLY (by its "ply" first line).
//
//   ASSIGN_OR_RETURN(OpenedScene opened, OpenScene(path));
//   Render(opened.scene, ...);
#ifndef POINTFORWARD_ENGINE_RENDER_SCENE_SOURCE_H_
#define POINTFORWARD_ENGINE_RENDER_SCENE_SOURCE_H_

#include <map>
#include <string>

#include "absl/status/statusor.h"
#include "engine/render/gaussian_scene.h"

namespace pf {

struct OpenedScene {
  GaussianScene scene;
  std::string format;    // "pointforward scene v1" or "3dgs ply".
  std::string scene_id;  // Scene file checksum, or the SHA-256 of the PLY file.
  std::string model;     // metadata["model"], "3dgs-ply", or "unknown".
  std::map<std::string, std::string> metadata;
};

// Loads the scene at `path`. NOT_FOUND when missing; INVALID_ARGUMENT when
// it is neither format or fails to load (the loaders' messages).
absl::StatusOr<OpenedScene> OpenScene(const std::string& path);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RENDER_SCENE_SOURCE_H_
