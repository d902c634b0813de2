// Checks of workers' results: see task_results.h.
#include "server/task_results.h"

#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <map>
#include <utility>

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

// INVALID_ARGUMENT unless frames [first, first + count) are frames of the job.
absl::Status CheckChunkRange(const v1::RenderViews& views, int first, int count) {
  const int64_t frames = RenderItemCount(views);
  if (first < 0 || count < 1 || int64_t{first} + count > frames) {
    return absl::InvalidArgumentError(absl::StrCat(
        "frames [", first, ", ", int64_t{first} + count, ") are not frames of the job (it has ",
        views.views_size(), " views and ", views.lidars_size(), " lidars)"));
  }
  return absl::OkStatus();
}

// Checks that each of `entries` (a chunk's manifest entries under `field`)
// has "name" names[i] and each of `members` set to names[i] + its suffix.
absl::Status CheckEntryNames(const Json& entries, const std::vector<std::string>& names,
                             const std::string& field,
                             std::initializer_list<std::pair<const char*, const char*>> members) {
  for (size_t i = 0; i < names.size(); ++i) {
    const Json& entry = entries[i];
    const std::string& name = names[i];
    bool ok = StringMember(entry, "name") == name;
    std::string files;
    for (const auto& [member, suffix] : members) {
      ok = ok && StringMember(entry, member) == name + suffix;
      absl::StrAppend(&files, files.empty() ? "" : ", ", name, suffix);
    }
    if (!ok) {
      return Invalid(absl::StrCat(field, "[", i, "]"),
                     absl::StrCat("does not describe '", name, "' (", files, ")"));
    }
  }
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<v1::RenderViews> RenderChunkViews(const v1::RenderViews& views, int first,
                                                 int count) {
  RETURN_IF_ERROR(CheckChunkRange(views, first, count));
  v1::RenderViews chunk;
  *chunk.mutable_cameras() = views.cameras();
  *chunk.mutable_edits() = views.edits();
  for (int i = first; i < first + count; ++i) {
    if (i < views.views_size()) {
      *chunk.add_views() = views.views(i);
    } else {
      *chunk.add_lidars() = views.lidars(i - views.views_size());
    }
  }
  return chunk;
}

absl::StatusOr<RenderChunkNames> ChunkOutputNames(const v1::RenderViews& views, int first,
                                                  int count) {
  RETURN_IF_ERROR(CheckChunkRange(views, first, count));
  RenderChunkNames names;
  for (int i = first; i < first + count; ++i) {
    if (i < views.views_size()) {
      names.views.push_back(RenderViewName(views.views(i)));
    } else {
      names.lidars.push_back(RenderLidarName(views.lidars(i - views.views_size())));
    }
  }
  return names;
}

absl::StatusOr<Json> ParseManifestViews(const std::string& json, int count) {
  const JsonLimits limits{.max_bytes = kMaxManifestBytesPerView * std::max(count, 1),
                          .max_depth = JsonLimits{}.max_depth};
  ASSIGN_OR_RETURN(Json entries, ParseBoundedJson(json, limits));
  if (!entries.is_array()) return absl::InvalidArgumentError("not a JSON array");
  if (entries.size() != static_cast<size_t>(count)) {
    return absl::InvalidArgumentError(
        absl::StrCat(entries.size(), " entries for the chunk's ", count, " frames"));
  }
  for (size_t i = 0; i < entries.size(); ++i) {
    if (!entries[i].is_object()) {
      return absl::InvalidArgumentError(absl::StrCat("entry ", i, " is not a JSON object"));
    }
  }
  return entries;
}

absl::Status CheckRenderResult(const v1::RenderResult& result, const RenderChunkNames& names) {
  // Expected file name -> its view or sweep.
  std::map<std::string, std::string> expected;
  for (const auto& [stems, suffixes] :
       {std::pair{&names.views, kViewFileSuffixes}, std::pair{&names.lidars, kLidarFileSuffixes}}) {
    for (const std::string& stem : *stems) {
      for (const char* suffix : suffixes) expected[stem + suffix] = stem;
    }
  }
  std::map<std::string, int> seen;  // Name -> index in files.
  for (int i = 0; i < result.files_size(); ++i) {
    const v1::OutputFile& file = result.files(i);
    const std::string field = absl::StrCat("render.files[", i, "]");
    const auto wanted = expected.find(file.name());
    if (wanted == expected.end()) {
      return Invalid(field + ".name",
                     absl::StrCat("'", file.name(), "' is not an output of the chunk's frames"));
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
      return Invalid("render.files", absl::StrCat("no '", name, "' for '", view, "'"));
    }
  }
  absl::StatusOr<Json> views =
      ParseManifestViews(result.manifest_views_json(), static_cast<int>(names.views.size()));
  if (!views.ok()) {
    return Invalid("render.manifest_views_json", std::string(views.status().message()));
  }
  RETURN_IF_ERROR(CheckEntryNames(*views, names.views, "render.manifest_views_json",
                                  {{"exr", kViewFileSuffixes[0]}, {"png", kViewFileSuffixes[1]}}));
  if (names.lidars.empty() && result.manifest_lidars_json().empty()) return absl::OkStatus();
  absl::StatusOr<Json> lidars =
      ParseManifestViews(result.manifest_lidars_json(), static_cast<int>(names.lidars.size()));
  if (!lidars.ok()) {
    return Invalid("render.manifest_lidars_json", std::string(lidars.status().message()));
  }
  return CheckEntryNames(*lidars, names.lidars, "render.manifest_lidars_json",
                         {{"rangeExr", kLidarFileSuffixes[0]}, {"points", kLidarFileSuffixes[1]}});
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
