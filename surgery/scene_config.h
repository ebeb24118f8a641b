// The "simulation" section of a scene (docs/fem.md): parsed and validated into the FEM's
// settings, with errors naming the scene file and the JSON pointer.
#pragma once

#include "blobvk/blobtree/program.h"
#include "blobvk/fem/simulation.h"
#include "blobvk/fem/tetgen_mesher.h"

#include <array>
#include <optional>
#include <string>
#include <vector>

namespace blobvk::surgery {

struct BladeKeyframe {
  double time = 0;
  mesh::Double3 a, b;  // blade segment end points
};

// A scripted rigid "lift" for `blobvk cut` (docs/scene-format.md): once cutting has freed the
// part nearest `near` (it no longer holds a fixed node) and the time is at least `start`, that
// part's nodes are pinned and carried along `path` (times relative to the lift's start; the
// rotation turns about the part's centroid at the start, then the translation is added), as a
// grasping tool would lift a bone flap away.
struct LiftKeyframe {
  double time = 0;
  mesh::Double3 translation;
  std::array<double, 4> rotation{1, 0, 0, 0};  // unit quaternion (w, x, y, z)
};
struct LiftConfig {
  mesh::Double3 near;
  double start = 0;
  std::vector<LiftKeyframe> path;
};

struct SimulationConfig {
  std::string mesher = "voxel";  // voxel | tetgen
  // Scenes default to TetGen's -o/150 on top of TetgenOptions' defaults: without it TetGen leaves
  // more slivers than the pass after it can remove (docs/performance.md, TetGen).
  fem::TetgenOptions tetgen = [] {
    fem::TetgenOptions o;
    o.optimizeMaxDihedralDegrees = 150;
    return o;
  }();
  // Target edge length of the surface clean-up before TetGen (mesh::remeshSurface), in
  // polygonizer cells; 0 feeds TetGen the raw marching-cubes surface. 2 cells: ~100k tets on
  // the craniotomy at >= 10 degrees in ~1.6 s (1.5 cells: ~210k tets in ~2.4 s).
  double tetgenRemeshEdgeCells = 2.0;
  double voxelCellSize = 0;      // 0: twice the polygonization cell size
  fem::SimulationSettings settings;
  std::optional<blobtree::Program> fixedSelector;  // nodes where this field >= 0.5 are fixed
  bool materialFromPrimitive = false;
  std::vector<BladeKeyframe> blade;  // optional scalpel path for `blobvk cut`
  std::optional<LiftConfig> lift;   // optional scripted lift of a cut-free part (`blobvk cut`)
  int steps = 0;                     // default step count (0: the CLI's)
  int frameEvery = 1;
};

// `json` is the section's text; `file` names the scene in error messages.
SimulationConfig parseSimulationConfig(const std::string& json, const std::string& file);

// A blade path file (`blobvk cut --blade`): {"blade": [{"t", "a", "b"}, ...]}, the simulation
// section's `blade` alone; errors name `file` and the pointer in it.
std::vector<BladeKeyframe> parseBladePath(const std::string& json, const std::string& file);

}  // namespace blobvk::surgery
