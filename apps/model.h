// Loading a scene file and compiling it, with errors that name the file.
#pragma once

#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/blobtree/tree.h"

#include <optional>
#include <string>

namespace blobvk::app {

struct Model {
  std::string path;
  blobtree::Scene scene;
  blobtree::Program program;
};

Model loadModel(const std::string& path);

// The box to frame and to ray-march: the model's bounds, or, where those are infinite (an
// unbounded warp at the root), the scene's grid bounds when it gives them.
blobtree::Aabb viewBounds(const Model& model);

// The grid for a model from the scene's grid section and the command line.
blobtree::GridSpec gridFor(const Model& model, std::optional<float> cellSize,
                           std::optional<int> resolution);

}  // namespace blobvk::app
