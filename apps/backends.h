// The polygonizer backends behind `mesh`, `bench` and `compare`, chosen by name.
#pragma once

#include "blobtree/grid.h"
#include "blobtree/program.h"
#include "mesh/trimesh.h"

#include <string>
#include <vector>

namespace blobvk::app {

struct PolygonizeSettings {
  std::string backend = "cpu";  // cpu (MPU + AVX), reference (scalar, one thread), vk
  int threads = 0;              // cpu: 0 = all cores
  int refineSteps = 0;
  int mpuSize = 0;              // cpu: cells per MPU side, 0 = default
  std::string device;           // vk: name substring or index
  bool validation = false;      // vk: Khronos validation layer
  bool stackBased = false;      // vk: the stack-based traversal instead of the stackless code
};

struct PolygonizeStats {
  double seconds = 0.0;
  double pointEvaluations = 0.0;  // field evaluations, where the backend counts them
};

std::vector<std::string> backendNames();

mesh::TriMesh polygonize(const blobtree::Program& program, const blobtree::GridSpec& grid,
                         const PolygonizeSettings& settings, PolygonizeStats* stats = nullptr);

}  // namespace blobvk::app
