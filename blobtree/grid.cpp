#include "blobvk/blobtree/grid.h"

#include "blobvk/blobtree/tree.h"

#include <glm/common.hpp>

#include <algorithm>
#include <cmath>
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
        "the model is unbounded (a bend or strong taper warp at the top); give grid.bounds in the "
        "scene");
  }
  const glm::vec3 extent = box.hi - box.lo;
  const float longest = std::max({extent.x, extent.y, extent.z, 1e-6f});

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
    throw std::invalid_argument("grid of " + std::to_string(std::llround(cellsLongest)) +
                                " cells along the longest side is too fine (limit 65536)");
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
