#include "model.h"

#include "blobvk/blobtree/scene_io.h"

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

blobtree::GridSpec gridFor(const Model& model, std::optional<float> cellSize,
                           std::optional<int> resolution) {
  try {
    return blobtree::chooseGrid(model.program, model.scene.grid, {cellSize, resolution});
  } catch (const std::exception& e) {
    throw std::runtime_error(model.path + ": " + e.what());
  }
}

}  // namespace blobvk::app
