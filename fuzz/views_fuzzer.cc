// libFuzzer target: RenderViews JSON parsing against a small fixed scene with
// two instances ("car1", "ped2"), so that edits naming them get past the
// lookup and reach the trajectory checks.
#include <cstddef>
#include <cstdint>
#include <string>

#include "engine/render/views.h"

namespace {

pf::GaussianScene SceneWithTwoInstances() {
  pf::GaussianScene scene;
  scene.Resize(2);
  for (const char* id : {"car1", "ped2"}) {
    pf::InstanceTrack track;
    track.id = id;
    track.category = "car";
    track.boxes.push_back({0, {0, 0, 0}, {4, 2, 1.5}, {}});
    track.boxes.push_back({100000, {1, 0, 0}, {4, 2, 1.5}, {}});
    scene.instances.push_back(track);
  }
  scene.owners = {1, 2};
  return scene;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const pf::GaussianScene* const scene = new pf::GaussianScene(SceneWithTwoInstances());
  const std::string json(reinterpret_cast<const char*>(data), size);
  (void)pf::ParseRenderViews(json, *scene);
  return 0;
}
