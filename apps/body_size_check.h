// A warning for a soft body too coarse to deform like the model: a grid of a few cells gives a
// handful of tets (one, at --resolution 4 on a sphere), and the run would go on without a word.
#pragma once

#include "blobvk/surgery/tet_model.h"

#include <string>

namespace blobvk::app {

// Below this many tets a body bends as a few stiff blocks.
inline constexpr std::size_t kFewestUsefulTets = 100;

// Prints one warning line on stderr naming `scene`, the tet count and the setting that makes
// the body finer for its mesher (`voxelOption`: the command's voxel-cell option, or empty when
// it has none); silent for bodies of kFewestUsefulTets tets or more.
void warnIfCoarseBody(const surgery::TetModel& body, const std::string& scene, const std::string& voxelOption);

}  // namespace blobvk::app
