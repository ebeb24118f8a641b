// The "simulation" section of a scene (docs/fem.md): parsed and validated into the FEM's
// settings, with errors naming the scene file and the JSON pointer.
#pragma once

#include "blobtree/program.h"
#include "fem/simulation.h"
#include "fem/tetgen_mesher.h"

#include <optional>
#include <string>

namespace blobvk::app {

struct BladeKeyframe {
  double time = 0;
  mesh::Double3 a, b;  // blade segment end points
};

struct SimulationConfig {
  std::string mesher = "voxel";  // voxel | tetgen
  fem::TetgenOptions tetgen;
  double voxelCellSize = 0;      // 0: twice the polygonization cell size
  fem::SimulationSettings settings;
  std::optional<blobtree::Program> fixedSelector;  // nodes where this field >= 0.5 are fixed
  bool materialFromPrimitive = false;
  std::vector<BladeKeyframe> blade;  // optional scalpel path for `blobvk cut`
  int steps = 0;                     // default step count (0: the CLI's)
  int frameEvery = 1;
};

// `json` is the section's text; `file` names the scene in error messages.
SimulationConfig parseSimulationConfig(const std::string& json, const std::string& file);

}  // namespace blobvk::app
