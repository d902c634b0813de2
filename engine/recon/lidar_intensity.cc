// Voxel-averaged LiDAR intensity onto Gaussians (lidar_intensity.h).
#include "engine/recon/lidar_intensity.h"

#include <array>
#include <cmath>
#include <iterator>

#include "absl/container/flat_hash_map.h"
#include "common/thread_pool.h"
#include "engine/recon/scene_graph.h"
#include "engine/render/instance_pose.h"

namespace pf {
namespace {

struct CellKey {
  uint32_t owner;
  int32_t x, y, z;
  bool operator==(const CellKey&) const = default;
  template <typename H>
  friend H AbslHashValue(H h, const CellKey& k) {
    return H::combine(std::move(h), k.owner, k.x, k.y, k.z);
  }
};

struct CellSum {
  double intensity = 0;
  int64_t count = 0;
};

using IntensityGrid = absl::flat_hash_map<CellKey, CellSum>;

int32_t CellIndex(double coordinate, double size) {
  return static_cast<int32_t>(std::floor(coordinate / size));
}

// The trilinear blend of the occupied cells around `p` (cell centres at
// (i + 0.5) size), renormalised over them; false when none has weight.
bool Blend(const IntensityGrid& grid, double size, uint32_t owner, const Vec3& p, float* out) {
  double base[3], frac[3];
  for (int a = 0; a < 3; ++a) {
    const double f = p[a] / size - 0.5;
    base[a] = std::floor(f);
    frac[a] = f - base[a];
  }
  double weight = 0, sum = 0;
  for (int corner = 0; corner < 8; ++corner) {
    double w = 1;
    CellKey key{owner, 0, 0, 0};
    int32_t* index[3] = {&key.x, &key.y, &key.z};
    for (int a = 0; a < 3; ++a) {
      const int bit = (corner >> a) & 1;
      *index[a] = static_cast<int32_t>(base[a]) + bit;
      w *= bit ? frac[a] : 1 - frac[a];
    }
    if (!(w > 0)) continue;
    const auto it = grid.find(key);
    if (it == grid.end()) continue;
    weight += w;
    sum += w * it->second.intensity / static_cast<double>(it->second.count);
  }
  if (!(weight > 0)) return false;
  *out = static_cast<float>(sum / weight);
  return true;
}

}  // namespace

LidarIntensityStats FuseLidarIntensity(const std::vector<const LidarSweepData*>& sweeps,
                                       int channel, GaussianScene* scene) {
  LidarIntensityStats stats;
  const std::vector<InstanceTrack>& tracks = scene->instances;
  std::array<IntensityGrid, std::size(kIntensityCells)> grids;
  for (const LidarSweepData* sweep : sweeps) {
    const size_t n = sweep->points.size() / 3;
    if (sweep->intensities.size() != n) continue;
    const BoxesAt boxes(tracks, sweep->timestamp_us);
    // canonical <- world at the sweep's time, per track.
    std::vector<Rigid> to_canonical(tracks.size());
    for (size_t k = 0; k < tracks.size(); ++k) {
      if (boxes.valid(k)) {
        to_canonical[k] = InstancePoseAt(tracks[k].boxes, sweep->timestamp_us).Inverse();
      }
    }
    for (size_t i = 0; i < n; ++i) {
      Vec3 p{sweep->points[3 * i], sweep->points[3 * i + 1], sweep->points[3 * i + 2]};
      const float intensity = sweep->intensities[i];
      if (!std::isfinite(intensity)) continue;
      const uint32_t owner = tracks.empty() ? 0 : boxes.Owner(p, kMembershipMargin);
      if (owner != 0) p = to_canonical[owner - 1] * p;
      for (size_t level = 0; level < grids.size(); ++level) {
        const double size = kIntensityCells[level];
        CellSum& cell = grids[level][CellKey{owner, CellIndex(p.x, size), CellIndex(p.y, size),
                                             CellIndex(p.z, size)}];
        cell.intensity += intensity;
        ++cell.count;
      }
      ++stats.points;
    }
  }
  const int stride = scene->num_channels;
  const int64_t count = static_cast<int64_t>(scene->size());
  std::vector<uint8_t> level_of(static_cast<size_t>(count), 0);  // 0: none; else level + 1.
  DefaultThreadPool().ParallelFor(0, count, 4096, [&](int64_t b, int64_t e) {
    for (int64_t i = b; i < e; ++i) {
      const Vec3 p{scene->means[3 * i], scene->means[3 * i + 1], scene->means[3 * i + 2]};
      float& value = scene->features[static_cast<size_t>(i) * stride + channel];
      value = 0.f;
      for (size_t level = 0; level < grids.size(); ++level) {
        if (Blend(grids[level], kIntensityCells[level], scene->owners[i], p, &value)) {
          level_of[i] = static_cast<uint8_t>(level + 1);
          break;
        }
      }
    }
  });
  for (uint8_t level : level_of) {
    stats.assigned += level > 0;
    stats.finest += level == 1;
  }
  return stats;
}

}  // namespace pf
