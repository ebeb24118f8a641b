// Where a vertex sits on its crossing edge: the parameter t kept within
// [layout::CROSSING_MIN, layout::CROSSING_MAX] (shaders/program_layout.h says why), as
// cpu_simd/reference_polygonizer.cpp's rule 2 states and shaders/edge_vertex.glsl does with
// clamp(): min and max are exact, so every polygonizer gives the same bits.
#pragma once

#include "blobvk/blobtree/program.h"

#include <algorithm>

namespace blobvk::cpu {

inline float crossingWithinEdge(float t) { return std::min(std::max(t, layout::CROSSING_MIN), layout::CROSSING_MAX); }

}  // namespace blobvk::cpu
