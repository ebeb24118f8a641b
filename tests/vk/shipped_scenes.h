// The shipped scenes (scenes/*.json) for the Vulkan tests: their names, sorted (the parameter
// list of the tests that run on every scene), one loaded on its own grid at a resolution, and a
// byte comparison of two arrays.
#pragma once

#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/blobtree/scene_io.h"

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

namespace blobvk::testing {

inline std::vector<std::string> shippedSceneNames() {
  std::vector<std::string> names;
  for (const auto& e : std::filesystem::directory_iterator(std::string(BLOBVK_SOURCE_DIR) + "/scenes"))
    if (e.path().extension() == ".json") names.push_back(e.path().stem().string());
  std::sort(names.begin(), names.end());
  return names;
}

struct ShippedScene {
  blobtree::Program program;
  blobtree::GridSpec grid;
};

// scenes/<name>.json compiled, on its grid settings with `resolution` cells along the longest side.
inline ShippedScene shipped(const std::string& name, int resolution) {
  const auto scene = blobtree::loadScene(std::string(BLOBVK_SOURCE_DIR) + "/scenes/" + name + ".json");
  ShippedScene s{blobtree::compile(scene.root), {}};
  blobtree::GridRequest request;
  request.resolution = resolution;
  s.grid = blobtree::chooseGrid(s.program, scene.grid, request);
  return s;
}

// A generated program's own grid (its bounds) at `resolution` cells along the longest side.
inline blobtree::GridSpec gridAt(const blobtree::Program& program, int resolution) {
  blobtree::GridRequest request;
  request.resolution = resolution;
  return blobtree::chooseGrid(program, {}, request);
}

template <class T, class A, class B>
bool sameBytes(const std::vector<T, A>& a, const std::vector<T, B>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0;
}

}  // namespace blobvk::testing
