// `blobvk compare --images`: renders the CPU mesh, the GPU mesh and the ray-cast of a scene and
// reports per-pixel differences. Implemented with the renderer (vk/render*).
#pragma once

#include "blobvk/blobtree/grid.h"
#include "model.h"

#include <nlohmann/json_fwd.hpp>

#include <string>

namespace blobvk::app {

struct ImageCompareSettings {
  std::string device;
  bool validation = false;
  int width = 256, height = 256;
  double tolerance = 0.1;          // per-channel difference counted as "over"
  double maxFractionOver = 0.02;   // fail beyond this fraction of pixels over tolerance
  std::string writeDir;            // optional: write the three images and the diffs here
};

// Fills `report` (JSON) and returns true when every pair is within the thresholds.
bool compareImages(const Model& model, const blobtree::GridSpec& grid,
                   const ImageCompareSettings& settings, nlohmann::json& report);

}  // namespace blobvk::app
