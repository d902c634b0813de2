// Deterministic randomness for the synthetic scene: a seeded generator for
// the scene layout and stateless integer hashes for procedural textures.
// Both are defined here (not with <random> distributions) so that a seed
// gives the same scene with any standard library.
#ifndef POINTFORWARD_ENGINE_SYNTH_SYNTH_RANDOM_H_
#define POINTFORWARD_ENGINE_SYNTH_SYNTH_RANDOM_H_

#include <cmath>
#include <cstdint>

namespace pf {

// SplitMix64: a small, fast, well-mixed generator; the stream is fixed by the
// seed.
class SynthRng {
 public:
  explicit SynthRng(uint64_t seed) : state_(seed ^ 0x9E3779B97F4A7C15ull) {}

  uint64_t Next() {
    uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  // Returns a double in [0, 1).
  double Unit() { return static_cast<double>(Next() >> 11) * 0x1.0p-53; }
  // Returns a double in [lo, hi).
  double Uniform(double lo, double hi) { return lo + (hi - lo) * Unit(); }
  // Returns an integer in [lo, hi].
  int UniformInt(int lo, int hi) {
    return lo + static_cast<int>(Next() % static_cast<uint64_t>(hi - lo + 1));
  }
  uint32_t NextU32() { return static_cast<uint32_t>(Next() >> 32); }

 private:
  uint64_t state_;
};

// Returns a well-mixed 32-bit hash of up to three integers.
inline uint32_t Hash3(uint32_t a, uint32_t b = 0, uint32_t c = 0) {
  uint32_t h = a * 0x9E3779B1u ^ (b + 0x7F4A7C15u) * 0x85EBCA77u ^ (c + 0x165667B1u) * 0xC2B2AE3Du;
  h ^= h >> 16;
  h *= 0x7FEB352Du;
  h ^= h >> 15;
  h *= 0x846CA68Bu;
  h ^= h >> 16;
  return h;
}

// Returns a hash of the integers mapped to [0, 1).
inline double HashUnit(uint32_t a, uint32_t b = 0, uint32_t c = 0) {
  return static_cast<double>(Hash3(a, b, c)) * (1.0 / 4294967296.0);
}

// Returns the lattice cell index of `x` (floor), as the unsigned value the
// hashes take.
inline uint32_t Cell(double x) {
  return static_cast<uint32_t>(static_cast<int64_t>(std::floor(x)));
}

// Returns smooth value noise in [0, 1) at (x, y): hashed lattice values
// blended with a smoothstep.
inline double ValueNoise(double x, double y, uint32_t seed) {
  const double fx = std::floor(x), fy = std::floor(y);
  const uint32_t ix = Cell(x), iy = Cell(y);
  double tx = x - fx, ty = y - fy;
  tx = tx * tx * (3 - 2 * tx);
  ty = ty * ty * (3 - 2 * ty);
  const double v00 = HashUnit(ix, iy, seed), v10 = HashUnit(ix + 1, iy, seed);
  const double v01 = HashUnit(ix, iy + 1, seed), v11 = HashUnit(ix + 1, iy + 1, seed);
  return (v00 * (1 - tx) + v10 * tx) * (1 - ty) + (v01 * (1 - tx) + v11 * tx) * ty;
}

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_SYNTH_SYNTH_RANDOM_H_
