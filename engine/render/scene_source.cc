// Scene loading by content: our scene file or a 3DGS PLY.
#include "engine/render/scene_source.h"

#include <filesystem>
#include <fstream>

#include "absl/strings/str_cat.h"
#include "common/hash.h"
#include "common/status_macros.h"
#include "engine/render/ply_io.h"
#include "engine/render/scene_file.h"

namespace pf {

absl::StatusOr<OpenedScene> OpenScene(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) {
    return absl::NotFoundError(absl::StrCat(path, ": file not found"));
  }
  OpenedScene opened;
  if (LooksLikeSceneFile(path)) {
    ASSIGN_OR_RETURN(SceneFile file, ReadSceneFile(path));
    opened.scene = std::move(file.scene);
    opened.format = absl::StrCat("pointforward scene v", file.version);
    opened.scene_id = file.checksum_hex;
    opened.metadata = std::move(file.metadata);
    const auto model = opened.metadata.find("model");
    opened.model = model != opened.metadata.end() ? model->second : "unknown";
    return opened;
  }
  std::ifstream in(path, std::ios::binary);
  char start[4] = {};
  in.read(start, sizeof(start));
  if (!in || std::string(start, 3) != "ply") {
    return absl::InvalidArgumentError(
        absl::StrCat(path, ": neither a PointForward scene file nor a PLY file"));
  }
  ASSIGN_OR_RETURN(opened.scene, ImportPly(path));
  opened.format = "3dgs ply";
  ASSIGN_OR_RETURN(opened.scene_id, Sha256File(path));
  opened.model = "3dgs-ply";
  return opened;
}

}  // namespace pf
