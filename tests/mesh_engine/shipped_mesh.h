// A shipped scene polygonized by the scalar reference (the mesh every other polygonizer matches).
#pragma once

#include "blobvk/blobtree/scene_io.h"
#include "blobvk/cpu_simd/reference_polygonizer.h"

#include <string>

inline blobvk::mesh::TriMesh shippedMesh(const std::string& name, int resolution) {
  using namespace blobvk;
  const auto scene = blobtree::loadScene(std::string(BLOBVK_SOURCE_DIR) + "/scenes/" + name + ".json");
  const auto program = blobtree::compile(scene.root);
  blobtree::GridRequest request;
  request.resolution = resolution;
  return cpu::polygonizeReference(program, blobtree::chooseGrid(program, scene.grid, request));
}
