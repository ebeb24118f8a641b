#version 450
// Sparse extraction, pass 1 (vk/extract/sparse_polygonizer.cpp): one invocation per brick of
// B^3 cells decides whether the brick can hold part of the surface. A conservative interval of
// the Program's field over the brick's box of (B+1)^3 grid points: the register code run once
// over the box instead of a point, the same bound as the CPU's early discard
// (cpu_simd/field_bounds.cpp, mirrored here in float with outward margins): skips whose box
// misses the query box jump as they would for every point inside it, a primitive contributes
// [kernel(largest distance), kernel(smallest distance)] between the box (mapped to its unit frame)
// and its skeleton's box, operators combine intervals. A brick whose interval lies below the iso
// value, or at or above it, by more than a rounding margin has every grid sample on one side: no
// crossing edge, no vertex, no triangle. Writes 1 (active) or 0 per brick, in (bz, by, bx) order;
// the word after the last brick is 0 (an exclusive scan then ends with the active count).
#extension GL_GOOGLE_include_directive : require
#include "program_layout.h"

layout(std430, set = 0, binding = 0) readonly buffer ProgramCode { Instruction programCode[]; };
layout(std430, set = 0, binding = 1) readonly buffer ProgramPrims { PrimitiveRecord programPrims[]; };
layout(std430, set = 0, binding = 2) readonly buffer ProgramMatrices { MatrixRecord programMatrices[]; };
layout(std430, set = 0, binding = 3) readonly buffer ProgramBoxes { BoxRecord programBoxes[]; };
layout(std430, set = 0, binding = 4) readonly buffer ProgramWarps { WarpRecord programWarps[]; };
#include "brick_classify_body.glsl"
