// SceneCache: an LRU list with a name index, under one mutex.
#include "worker/scene_cache.h"

#include <utility>

namespace pf {
namespace {

template <typename T>
int64_t VectorBytes(const std::vector<T>& v) {
  return static_cast<int64_t>(v.size() * sizeof(T));
}

}  // namespace

SceneCache::SceneCache(int64_t budget_bytes) : budget_bytes_(budget_bytes) {}

int64_t SceneCache::EstimateBytes(const GaussianScene& scene) {
  int64_t bytes = VectorBytes(scene.means) + VectorBytes(scene.rotations) +
                  VectorBytes(scene.log_scales) + VectorBytes(scene.opacity_logits) +
                  VectorBytes(scene.features) + VectorBytes(scene.sh) + VectorBytes(scene.times) +
                  VectorBytes(scene.lifespans) + VectorBytes(scene.owners) +
                  VectorBytes(scene.colour_gradients);
  for (const InstanceTrack& track : scene.instances) bytes += VectorBytes(track.boxes);
  return bytes;
}

std::shared_ptr<const OpenedScene> SceneCache::Get(const std::string& name) {
  std::lock_guard<std::mutex> lock(mu_);
  const auto it = index_.find(name);
  if (it == index_.end()) {
    ++misses_;
    return nullptr;
  }
  ++hits_;
  lru_.splice(lru_.begin(), lru_, it->second);
  std::shared_ptr<const OpenedScene> scene = it->second->scene;
  // Scenes released since the last Put may now be evictable.
  EvictLocked();
  return scene;
}

std::shared_ptr<const OpenedScene> SceneCache::Put(const std::string& name, OpenedScene scene) {
  Entry entry;
  entry.name = name;
  entry.bytes = EstimateBytes(scene.scene);
  entry.scene = std::make_shared<const OpenedScene>(std::move(scene));
  std::shared_ptr<const OpenedScene> result = entry.scene;

  std::lock_guard<std::mutex> lock(mu_);
  const auto old = index_.find(name);
  if (old != index_.end()) {
    bytes_ -= old->second->bytes;
    lru_.erase(old->second);
    index_.erase(old);
  }
  bytes_ += entry.bytes;
  lru_.push_front(std::move(entry));
  index_[name] = lru_.begin();
  EvictLocked();
  return result;
}

void SceneCache::EvictLocked() {
  auto it = lru_.end();
  while (bytes_ > budget_bytes_ && it != lru_.begin()) {
    --it;
    // The cache's own reference is one; more means a task still uses it.
    if (it->scene.use_count() > 1) continue;
    bytes_ -= it->bytes;
    index_.erase(it->name);
    it = lru_.erase(it);
    ++evictions_;
  }
}

std::vector<std::string> SceneCache::Names() const {
  std::lock_guard<std::mutex> lock(mu_);
  std::vector<std::string> names;
  names.reserve(lru_.size());
  for (const Entry& entry : lru_) names.push_back(entry.name);
  return names;
}

int64_t SceneCache::bytes() const {
  std::lock_guard<std::mutex> lock(mu_);
  return bytes_;
}

int64_t SceneCache::hits() const {
  std::lock_guard<std::mutex> lock(mu_);
  return hits_;
}

int64_t SceneCache::misses() const {
  std::lock_guard<std::mutex> lock(mu_);
  return misses_;
}

int64_t SceneCache::evictions() const {
  std::lock_guard<std::mutex> lock(mu_);
  return evictions_;
}

}  // namespace pf
