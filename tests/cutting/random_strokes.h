// The random kinked strokes of the TetGen-ball tests (tetgen_strokes_test, sliver_sources_test):
// each stroke is cut as surgery::SoftBody cuts it, in three blade steps (each step's event also
// re-cuts the previous step) and a final pass over the whole stroke.
#pragma once

#include "blobvk/cutting/blade.h"

#include <random>
#include <vector>

namespace blobvk::cutting::test {

// The swept triangles of each event of one stroke, in order (3 steps, then the whole stroke).
using StrokeEvents = std::vector<std::vector<Triangle>>;

class RandomStrokes {
 public:
  explicit RandomStrokes(unsigned seed) : rng_(seed) {}
  // The next stroke: centre in [-0.5, 0.5]^3, blade half-length 0.25-0.6, travel 0.3-0.8, the
  // blade turning while it moves (the stroke's surface is not planar).
  StrokeEvents next();

 private:
  std::mt19937 rng_;
};

}  // namespace blobvk::cutting::test
