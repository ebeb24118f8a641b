// Loading a scene file and compiling it, with errors that name the file.
#pragma once

#include "blobtree/grid.h"
#include "blobtree/program.h"
#include "blobtree/tree.h"

#include <optional>
#include <string>

namespace blobvk::app {

struct Model {
  std::string path;
  blobtree::Scene scene;
  blobtree::Program program;
};

Model loadModel(const std::string& path);

// The grid for a model from the scene's grid section and the command line.
blobtree::GridSpec gridFor(const Model& model, std::optional<float> cellSize,
                           std::optional<int> resolution);

}  // namespace blobvk::app
