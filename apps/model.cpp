#include "model.h"

#include "number_checks.h"

#include "blobvk/blobtree/scene_io.h"

#include <array>
#include <stdexcept>

namespace blobvk::app {

Model loadModel(const std::string& path) {
  Model model;
  model.path = path;
  model.scene = blobtree::loadScene(path);  // SceneError already names the file and place
  try {
    model.program = blobtree::compile(model.scene.root);
  } catch (const std::exception& e) {
    throw std::runtime_error(path + ": cannot compile the model: " + e.what());
  }
  return model;
}

blobtree::Aabb viewBounds(const Model& model) {
  if (model.program.bounds.finite() || !model.scene.grid.boundsLo || !model.scene.grid.boundsHi) return model.program.bounds;
  blobtree::Aabb box;
  box.lo = glm::vec3(*model.scene.grid.boundsLo);
  box.hi = glm::vec3(*model.scene.grid.boundsHi);
  return box;
}

void applyGridBounds(Model& model, const std::string& bounds) {
  if (bounds.empty()) return;
  const std::array<double, 6> v = parseGridBounds(bounds);
  model.scene.grid.boundsLo = blobtree::Vec3(v[0], v[1], v[2]);
  model.scene.grid.boundsHi = blobtree::Vec3(v[3], v[4], v[5]);
}

std::string gridPlace(const Model& model, std::optional<float> cellSize, std::optional<int> resolution) {
  if (cellSize || resolution) return "";
  const auto& g = model.scene.grid;
  if (g.cellSize) return model.path + ": /grid/cellSize: ";
  if (g.resolution) return model.path + ": /grid/resolution: ";
  return "";
}

blobtree::GridSpec gridFor(const Model& model, std::optional<float> cellSize,
                           std::optional<int> resolution) {
  try {
    return blobtree::chooseGrid(model.program, model.scene.grid, {cellSize, resolution});
  } catch (const std::exception& e) {
    const blobtree::Aabb& b = model.program.bounds;
    const bool gridBounds = model.scene.grid.boundsLo && model.scene.grid.boundsHi;
    // A legacy file has no grid section to put the bounds in: name the option that gives them.
    const bool unbounded = !gridBounds && !b.finite() && !b.empty();
    // The box comes first (an empty or unbounded model is no fault of the grid's size keys).
    const bool boxFine = gridBounds || (!b.empty() && b.finite());
    const std::string place = boxFine ? gridPlace(model, cellSize, resolution) : "";
    throw std::runtime_error((place.empty() ? model.path + ": " : place) + e.what() +
                             (unbounded ? " or --bounds x0,y0,z0,x1,y1,z1" : ""));
  }
}

}  // namespace blobvk::app
