// libFuzzer target: what a worker sends back, as the server checks it
// (server/task_results.h). The input is a CompleteTaskRequest in proto3 JSON
// (parsed with the bounded parser every stored row goes through), checked
// against a fixed chunk of two views "v00" and "v01" and a LiDAR sweep
// "top"; the input is also read as a chunk's manifest_views_json directly, as
// the server reads one back from its store.
#include <cstddef>
#include <cstdint>
#include <string>

#include "common/bounded_json.h"
#include "pointforward/v1/worker.pb.h"
#include "server/task_results.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const pf::RenderChunkNames* const kNames =
      new pf::RenderChunkNames{{"v00", "v01"}, {"top"}};
  const std::string text(reinterpret_cast<const char*>(data), size);
  pointforward::v1::CompleteTaskRequest request;
  if (pf::ParseBoundedProtoJson(text, &request, pf::kStoredJsonLimits).ok()) {
    if (request.has_render()) {
      (void)pf::CheckRenderResult(request.render(), *kNames);
      (void)pf::ParseManifestViews(request.render().manifest_views_json(), 2);
      (void)pf::ParseManifestViews(request.render().manifest_lidars_json(), 1);
    }
    if (request.has_reconstruct()) (void)pf::CheckReconstructResult(request.reconstruct());
  }
  const auto views = pf::ParseManifestViews(text, 2);
  if (views.ok()) (void)views->dump();
  return 0;
}
