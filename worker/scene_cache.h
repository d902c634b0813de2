// The worker's in-memory scenes: opened scene files kept under a byte budget
// so that render chunks of a recently used scene skip the download and load.
// The least recently used scene goes first; a scene still held by a running
// task (someone else owns a reference) is never evicted, so the cache may
// stay above its budget until that task lets go.
//
//   SceneCache cache(2LL << 30);
//   std::shared_ptr<const OpenedScene> scene = cache.Get("scenes/abc");
//   if (scene == nullptr) scene = cache.Put("scenes/abc", OpenScene(path).value());
//
// Thread-safe.
#ifndef POINTFORWARD_WORKER_SCENE_CACHE_H_
#define POINTFORWARD_WORKER_SCENE_CACHE_H_

#include <cstdint>
#include <list>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "engine/render/gaussian_scene.h"
#include "engine/render/scene_source.h"

namespace pf {

class SceneCache {
 public:
  explicit SceneCache(int64_t budget_bytes);

  // Returns the scene cached under `name` and marks it most recently used,
  // or nullptr. Counts a hit or a miss.
  std::shared_ptr<const OpenedScene> Get(const std::string& name);

  // Caches `scene` under `name` (replacing an entry of that name) as the most
  // recently used, then evicts unused scenes, least recently used first,
  // until the total is within the budget. Returns the cached scene; while the
  // caller holds it, it is not evicted.
  std::shared_ptr<const OpenedScene> Put(const std::string& name, OpenedScene scene);

  // Returns the names of the cached scenes, most recently used first.
  std::vector<std::string> Names() const;

  int64_t budget_bytes() const { return budget_bytes_; }
  int64_t bytes() const;
  int64_t hits() const;
  int64_t misses() const;
  int64_t evictions() const;

  // Returns the bytes of the arrays of `scene` (what the cache counts).
  static int64_t EstimateBytes(const GaussianScene& scene);

 private:
  struct Entry {
    std::string name;
    std::shared_ptr<const OpenedScene> scene;
    int64_t bytes = 0;
  };

  // Evicts unused entries from the back of lru_ until within budget.
  void EvictLocked();

  const int64_t budget_bytes_;
  mutable std::mutex mu_;
  std::list<Entry> lru_;  // Front: most recently used.
  std::map<std::string, std::list<Entry>::iterator> index_;
  int64_t bytes_ = 0;
  int64_t hits_ = 0;
  int64_t misses_ = 0;
  int64_t evictions_ = 0;
};

}  // namespace pf

#endif  // POINTFORWARD_WORKER_SCENE_CACHE_H_
