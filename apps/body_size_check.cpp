#include "body_size_check.h"

#include <cstdio>

namespace blobvk::app {

void warnIfCoarseBody(const surgery::TetModel& body, const std::string& scene, const std::string& voxelOption) {
  const std::size_t tets = body.tets.tetCount();
  if (tets >= kFewestUsefulTets) return;
  // TetGen meshes the polygonized surface (finer with the grid); the voxel mesher fills the
  // model with cubes of its own cell size.
  const std::string finer = body.config.mesher == "voxel"
                                ? "a smaller simulation.voxel.cellSize" + (voxelOption.empty() ? "" : " or " + voxelOption)
                                : "a larger --resolution";
  std::fprintf(stderr, "blobvk: warning: %s: the soft body has only %zu tet%s (%s mesher), too few to deform like the model; %s gives more\n",
               scene.c_str(), tets, tets == 1 ? "" : "s", body.config.mesher.c_str(), finer.c_str());
}

}  // namespace blobvk::app
