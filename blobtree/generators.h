// Procedural test models from the thesis (§7): the "Piza" tower, the eggshell, and random blobs.
// All are deterministic: the same arguments give the same tree on every platform.
#pragma once

#include "blobvk/blobtree/tree.h"

#include <cstdint>

namespace blobvk::blobtree {

// The thesis' tower: `levels` stacked levels, each a union of `pillars` pillars on a circle of
// `radius` and a ceiling disc of radius 1.2 * radius; a pillar is a base disc, a column
// (cylinder of radius 0.25 and height 0.7 * height) and a capital point. Levels are stacked every
// 1.1 * height along +y. grid > 1 replicates the tower on a grid x grid layout spaced 3 * radius.
// Throws std::invalid_argument for non-positive arguments.
Node generateTower(int levels, int pillars, double radius, double height, int grid);

// The FEM test object: DIFFERENCE of two points scaled (3.45, 2.18, 3.11) and (3.14, 1.76, 2.83).
Node generateEggshell();

// BLEND of n coloured points in a box that grows with n (so the density stays constant), placed
// by SplitMix64 from `seed`. Throws std::invalid_argument for n < 1.
Node generateRandomBlobs(int n, std::uint64_t seed);

// The same points joined by a Ricci blend of `power` (> 0), (sum f^power)^(1/power), instead of
// a blend. Throws std::invalid_argument for n < 1 or a power that is not positive.
Node generateRandomRicciBlobs(int n, std::uint64_t seed, double power);

// Vigna's SplitMix64: tiny, fast and fully specified, so generated models do not depend on the
// standard library's distributions (which are implementation-defined).
class SplitMix64 {
 public:
  explicit SplitMix64(std::uint64_t seed) : state_(seed) {}
  std::uint64_t next() {
    std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  // Uniform in [0, 1) with 53 random bits.
  double uniform() { return double(next() >> 11) * 0x1.0p-53; }
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }

 private:
  std::uint64_t state_;
};

}  // namespace blobvk::blobtree
