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

// `--bounds x0,y0,z0,x1,y1,z1` (number_checks.h gridBounds(), already checked) in place of the
// scene's grid.bounds: a region of the model, or bounds for one that has none (an unbounded
// warp; a legacy file, which has no grid section). Empty text changes nothing.
void applyGridBounds(Model& model, const std::string& bounds);
// The help text of that option, the same in every command that takes it.
inline constexpr const char* kGridBoundsHelp =
    "Grid bounds x0,y0,z0,x1,y1,z1 in place of the scene's grid.bounds (a region of the model; needed for an unbounded "
    "one, such as a legacy file with a bend)";

// The grid for a model from the scene's grid section and the command line.
blobtree::GridSpec gridFor(const Model& model, std::optional<float> cellSize,
                           std::optional<int> resolution);
// Where a problem with that grid's size lies, as a message prefix: "scene.json: /grid/resolution: "
// (or /grid/cellSize) when the scene's grid section sets it, else "" (an option names itself).
std::string gridPlace(const Model& model, std::optional<float> cellSize, std::optional<int> resolution);

}  // namespace blobvk::app
