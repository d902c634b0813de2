// Checks of workers' results: see task_results.h.
#include "server/task_results.h"

#include <algorithm>
#include <cmath>
#include <map>

#include "absl/strings/str_cat.h"
#include "common/bounded_json.h"
#include "common/status_macros.h"
#include "engine/render/views.h"

namespace pf {
namespace {

namespace v1 = pointforward::v1;
using Json = nlohmann::ordered_json;

constexpr int kMaxInstanceIdLength = 1024;
constexpr int kMaxInstances = 100000;

absl::Status Invalid(const std::string& field, const std::string& problem) {
  return absl::InvalidArgumentError(absl::StrCat(field, ": ", problem));
}

absl::Status CheckDigest(const v1::Digest& digest, const std::string& field) {
  const std::string& sha = digest.sha256();
  const bool hex = sha.size() == 64 && std::all_of(sha.begin(), sha.end(), [](char c) {
                     return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f');
                   });
  if (!hex) return Invalid(field + ".sha256", "not 64 lowercase hex digits");
  if (digest.size_bytes() < 0) return Invalid(field + ".size_bytes", "negative");
  return absl::OkStatus();
}

// The string member `key` of manifest entry `entry`, or "".
std::string StringMember(const Json& entry, const char* key) {
  const auto it = entry.find(key);
  return it != entry.end() && it->is_string() ? it->get<std::string>() : "";
}

// INVALID_ARGUMENT unless views [first_view, first_view + view_count) are in `views`.
absl::Status CheckChunkRange(const v1::RenderViews& views, int first_view, int view_count) {
  if (first_view < 0 || view_count < 1 ||
      int64_t{first_view} + view_count > int64_t{views.views_size()}) {
    return absl::InvalidArgumentError(
        absl::StrCat("views [", first_view, ", ", int64_t{first_view} + view_count,
                     ") are not views of the job (it has ", views.views_size(), ")"));
  }
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<v1::RenderViews> RenderChunkViews(const v1::RenderViews& views, int first_view,
                                                 int view_count) {
  RETURN_IF_ERROR(CheckChunkRange(views, first_view, view_count));
  v1::RenderViews chunk;
  *chunk.mutable_cameras() = views.cameras();
  *chunk.mutable_edits() = views.edits();
  for (int i = first_view; i < first_view + view_count; ++i) *chunk.add_views() = views.views(i);
  return chunk;
}

absl::StatusOr<std::vector<std::string>> RenderChunkViewNames(const v1::RenderViews& views,
                                                              int first_view, int view_count) {
  RETURN_IF_ERROR(CheckChunkRange(views, first_view, view_count));
  std::vector<std::string> names;
  names.reserve(view_count);
  for (int i = first_view; i < first_view + view_count; ++i) {
    names.push_back(RenderViewName(views.views(i)));
  }
  return names;
}

absl::StatusOr<Json> ParseManifestViews(const std::string& json, int view_count) {
  const JsonLimits limits{.max_bytes = kMaxManifestBytesPerView * std::max(view_count, 1),
                          .max_depth = JsonLimits{}.max_depth};
  ASSIGN_OR_RETURN(Json views, ParseBoundedJson(json, limits));
  if (!views.is_array()) return absl::InvalidArgumentError("not a JSON array");
  if (views.size() != static_cast<size_t>(view_count)) {
    return absl::InvalidArgumentError(
        absl::StrCat(views.size(), " entries for the chunk's ", view_count, " views"));
  }
  for (size_t i = 0; i < views.size(); ++i) {
    if (!views[i].is_object()) {
      return absl::InvalidArgumentError(absl::StrCat("entry ", i, " is not a JSON object"));
    }
  }
  return views;
}

absl::Status CheckRenderResult(const v1::RenderResult& result,
                               const std::vector<std::string>& view_names) {
  // Expected name -> its view.
  std::map<std::string, std::string> expected;
  for (const std::string& view : view_names) {
    expected[view + ".exr"] = view;
    expected[view + ".png"] = view;
  }
  std::map<std::string, int> seen;  // Name -> index in files.
  for (int i = 0; i < result.files_size(); ++i) {
    const v1::OutputFile& file = result.files(i);
    const std::string field = absl::StrCat("render.files[", i, "]");
    const auto wanted = expected.find(file.name());
    if (wanted == expected.end()) {
      return Invalid(field + ".name",
                     absl::StrCat("'", file.name(), "' is not an output of the chunk's views"));
    }
    if (!seen.emplace(file.name(), i).second) {
      return Invalid(field + ".name", absl::StrCat("'", file.name(), "' given twice"));
    }
    if (file.view() != wanted->second) {
      return Invalid(field + ".view",
                     absl::StrCat("'", file.view(), "', expected '", wanted->second, "'"));
    }
    RETURN_IF_ERROR(CheckDigest(file.digest(), field + ".digest"));
  }
  for (const auto& [name, view] : expected) {
    if (!seen.count(name)) {
      return Invalid("render.files", absl::StrCat("no '", name, "' for view '", view, "'"));
    }
  }
  absl::StatusOr<Json> entries =
      ParseManifestViews(result.manifest_views_json(), static_cast<int>(view_names.size()));
  if (!entries.ok())
    return Invalid("render.manifest_views_json", std::string(entries.status().message()));
  for (size_t i = 0; i < view_names.size(); ++i) {
    const Json& entry = (*entries)[i];
    const std::string& view = view_names[i];
    if (StringMember(entry, "name") != view || StringMember(entry, "exr") != view + ".exr" ||
        StringMember(entry, "png") != view + ".png") {
      return Invalid(
          absl::StrCat("render.manifest_views_json[", i, "]"),
          absl::StrCat("does not describe view '", view, "' (", view, ".exr, ", view, ".png)"));
    }
  }
  return absl::OkStatus();
}

absl::Status CheckReconstructResult(const v1::ReconstructResult& result) {
  const v1::Scene& scene = result.scene();
  RETURN_IF_ERROR(CheckDigest(scene.scene_file(), "reconstruct.scene.scene_file"));
  for (const auto& [name, count] : {std::pair<const char*, int64_t>{"gaussians", scene.gaussians()},
                                    {"static_gaussians", scene.static_gaussians()},
                                    {"dynamic_gaussians", scene.dynamic_gaussians()},
                                    {"far_gaussians", scene.far_gaussians()}}) {
    if (count < 0) return Invalid(absl::StrCat("reconstruct.scene.", name), "negative");
  }
  if (scene.num_channels() < 0 || scene.num_channels() > 1024) {
    return Invalid("reconstruct.scene.num_channels", absl::StrCat(scene.num_channels()));
  }
  if (scene.instances_size() > kMaxInstances) {
    return Invalid("reconstruct.scene.instances",
                   absl::StrCat(scene.instances_size(), " exceed ", kMaxInstances));
  }
  for (int i = 0; i < scene.instances_size(); ++i) {
    const size_t length = scene.instances(i).size();
    if (length < 1 || length > kMaxInstanceIdLength) {
      return Invalid(absl::StrCat("reconstruct.scene.instances[", i, "]"),
                     absl::StrCat("must be 1 to ", kMaxInstanceIdLength, " characters"));
    }
  }
  for (const auto& [name, bounds] : {std::pair{"bounds_min", &scene.bounds_min()},
                                     std::pair{"bounds_max", &scene.bounds_max()}}) {
    if (bounds->size() != 0 && bounds->size() != 3) {
      return Invalid(absl::StrCat("reconstruct.scene.", name), "expected 3 numbers or none");
    }
    for (double v : *bounds) {
      if (!std::isfinite(v)) return Invalid(absl::StrCat("reconstruct.scene.", name), "not finite");
    }
  }
  return absl::OkStatus();
}

}  // namespace pf
