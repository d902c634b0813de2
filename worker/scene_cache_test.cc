// Tests of SceneCache: eviction order under the byte budget, scenes in use
// kept, hit and miss counts.
#include "worker/scene_cache.h"

#include <memory>
#include <string>
#include <vector>

#include "gtest/gtest.h"

namespace pf {
namespace {

using Names = std::vector<std::string>;

// A scene of `n` background Gaussians with 3 channels: 4 * n * (3 + 4 + 3 +
// 1 + 3 + 1 + 1 + 1) = 68 * n bytes.
OpenedScene SceneOf(size_t n, const std::string& id) {
  OpenedScene opened;
  opened.scene.Resize(n);
  opened.scene_id = id;
  return opened;
}

constexpr int64_t kBytesPer100 = 6800;

TEST(SceneCache, EstimateIsTheSumOfTheArrays) {
  EXPECT_EQ(SceneCache::EstimateBytes(SceneOf(100, "a").scene), kBytesPer100);
  GaussianScene with_track = SceneOf(10, "b").scene;
  with_track.instances.push_back({"car", "car", std::vector<TrackBox>(2)});
  EXPECT_EQ(SceneCache::EstimateBytes(with_track), 680 + 2 * int64_t(sizeof(TrackBox)));
  GaussianScene textured = SceneOf(100, "c").scene;
  textured.colour_gradients.resize(6 * 100);  // 24 more bytes per Gaussian.
  EXPECT_EQ(SceneCache::EstimateBytes(textured), kBytesPer100 + 2400);
}

TEST(SceneCache, EvictsLeastRecentlyUsedFirst) {
  SceneCache cache(3 * kBytesPer100);
  cache.Put("scenes/a", SceneOf(100, "a"));
  cache.Put("scenes/b", SceneOf(100, "b"));
  cache.Put("scenes/c", SceneOf(100, "c"));
  EXPECT_EQ(cache.Names(), (Names{"scenes/c", "scenes/b", "scenes/a"}));
  EXPECT_EQ(cache.bytes(), 3 * kBytesPer100);

  // Touching a makes b the least recently used.
  ASSERT_NE(cache.Get("scenes/a"), nullptr);
  cache.Put("scenes/d", SceneOf(100, "d"));
  EXPECT_EQ(cache.Names(), (Names{"scenes/d", "scenes/a", "scenes/c"}));
  EXPECT_EQ(cache.Get("scenes/b"), nullptr);
  EXPECT_EQ(cache.evictions(), 1);

  // A scene of twice the size pushes out the two oldest.
  cache.Put("scenes/e", SceneOf(200, "e"));
  EXPECT_EQ(cache.Names(), (Names{"scenes/e", "scenes/d"}));
  EXPECT_EQ(cache.bytes(), 3 * kBytesPer100);
  EXPECT_EQ(cache.evictions(), 3);
}

TEST(SceneCache, SceneInUseIsNeverEvicted) {
  SceneCache cache(2 * kBytesPer100);
  std::shared_ptr<const OpenedScene> held = cache.Put("scenes/a", SceneOf(100, "a"));
  cache.Put("scenes/b", SceneOf(100, "b"));
  cache.Put("scenes/c", SceneOf(100, "c"));
  // a is the oldest but held: b goes instead.
  EXPECT_EQ(cache.Names(), (Names{"scenes/c", "scenes/a"}));
  EXPECT_EQ(held->scene_id, "a");

  // Over budget while everything is held: nothing can go.
  std::shared_ptr<const OpenedScene> c = cache.Get("scenes/c");
  std::shared_ptr<const OpenedScene> d = cache.Put("scenes/d", SceneOf(100, "d"));
  EXPECT_EQ(cache.Names(), (Names{"scenes/d", "scenes/c", "scenes/a"}));
  EXPECT_EQ(cache.bytes(), 3 * kBytesPer100);

  // Once a is released, the next access trims it.
  held.reset();
  EXPECT_NE(cache.Get("scenes/d"), nullptr);
  EXPECT_EQ(cache.Names(), (Names{"scenes/d", "scenes/c"}));
  EXPECT_EQ(cache.bytes(), 2 * kBytesPer100);
}

TEST(SceneCache, SceneLargerThanBudgetStaysWhileHeld) {
  SceneCache cache(kBytesPer100);
  std::shared_ptr<const OpenedScene> big = cache.Put("scenes/big", SceneOf(300, "big"));
  EXPECT_EQ(cache.Names(), (Names{"scenes/big"}));
  big.reset();
  cache.Put("scenes/small", SceneOf(50, "small"));
  EXPECT_EQ(cache.Names(), (Names{"scenes/small"}));
}

TEST(SceneCache, ReplacingANameKeepsOneEntry) {
  SceneCache cache(10 * kBytesPer100);
  cache.Put("scenes/a", SceneOf(100, "old"));
  cache.Put("scenes/a", SceneOf(200, "new"));
  EXPECT_EQ(cache.Names(), (Names{"scenes/a"}));
  EXPECT_EQ(cache.bytes(), 2 * kBytesPer100);
  EXPECT_EQ(cache.Get("scenes/a")->scene_id, "new");
}

TEST(SceneCache, CountsHitsAndMisses) {
  SceneCache cache(10 * kBytesPer100);
  EXPECT_EQ(cache.Get("scenes/a"), nullptr);
  cache.Put("scenes/a", SceneOf(10, "a"));
  EXPECT_NE(cache.Get("scenes/a"), nullptr);
  EXPECT_NE(cache.Get("scenes/a"), nullptr);
  EXPECT_EQ(cache.Get("scenes/b"), nullptr);
  EXPECT_EQ(cache.hits(), 2);
  EXPECT_EQ(cache.misses(), 2);
}

}  // namespace
}  // namespace pf
