#include "blobvk/blobtree/grid.h"

#include "blobvk/blobtree/tree.h"

#include <glm/common.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <string>

namespace blobvk::blobtree {

std::uint64_t GridSpec::pointCount() const {
  const glm::ivec3 p = points();
  return std::uint64_t(p.x) * std::uint64_t(p.y) * std::uint64_t(p.z);
}

GridSpec chooseGrid(const Program& program, const GridSettings& scene, const GridRequest& request) {
  Aabb box = program.bounds;
  if (scene.boundsLo && scene.boundsHi) {
    box.lo = glm::vec3(*scene.boundsLo);
    box.hi = glm::vec3(*scene.boundsHi);
  }
  if (box.empty()) {
    throw std::invalid_argument("the model is empty: its field is 0 everywhere");
  }
  if (!box.finite()) {
    throw std::invalid_argument(
        "the model is unbounded (a bend, or a strong taper, that no intersection or difference bounds); give "
        "grid.bounds in the scene");
  }
  const glm::vec3 extent = box.hi - box.lo;
  // A model of no extent (a degenerate box) still gets a grid; a small one gets its own size,
  // not a floor (a floor of 1e-6 left a model of 2e-8 with no cell inside it).
  float longest = std::max({extent.x, extent.y, extent.z});
  if (!(longest > 0.0f)) longest = 1e-6f;

  float cell = 0.0f;
  if (request.cellSize) cell = *request.cellSize;
  else if (request.resolution) cell = longest / float(*request.resolution);
  else if (scene.cellSize) cell = float(*scene.cellSize);
  else if (scene.resolution) cell = longest / float(*scene.resolution);
  else cell = longest / 128.0f;
  if (request.resolution && *request.resolution <= 0) {
    throw std::invalid_argument("resolution must be a positive number of cells");
  }
  if (!(cell > 0.0f) || !std::isfinite(cell)) {
    throw std::invalid_argument("cell size must be a positive finite number");
  }
  const double cellsLongest = std::ceil(double(longest) / double(cell));
  if (cellsLongest > 65536.0) {
    char text[120];  // %.0f: a count past 2^63 would overflow an integer conversion
    std::snprintf(text, sizeof text, "grid of %.0f cells along the longest side is too fine (limit 65536)", cellsLongest);
    throw std::invalid_argument(text);
  }

  // Grid points are floats: a cell under about four units in the last place of the coordinates it
  // spans would put neighbouring points on the same float, and the mesh would be noise.
  const float reach = std::max({std::abs(box.lo.x), std::abs(box.lo.y), std::abs(box.lo.z), std::abs(box.hi.x),
                                std::abs(box.hi.y), std::abs(box.hi.z)}) + cell;
  if (cell < 4.0f * reach * std::numeric_limits<float>::epsilon()) {
    char text[200];
    std::snprintf(text, sizeof text,
                  "cells of %.3g at coordinates up to %.3g are below float precision; scale the model, move it "
                  "nearer the origin or use coarser cells",
                  double(cell), double(reach));
    throw std::invalid_argument(text);
  }

  GridSpec grid;
  grid.cellSize = cell;
  grid.origin = box.lo - glm::vec3(cell);  // one cell of margin: the border is outside
  for (int a = 0; a < 3; ++a) {
    grid.cells[a] = int(std::ceil(double(extent[a]) / double(cell))) + 2;
  }
  return grid;
}

}  // namespace blobvk::blobtree
