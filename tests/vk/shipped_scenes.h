// The names of the shipped scenes (scenes/*.json, without extension), sorted: the parameter list
// of the Vulkan tests that run on every scene.
#pragma once

#include <algorithm>
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

}  // namespace blobvk::testing
