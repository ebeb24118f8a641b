#version 450
// Sparse extraction, pass 1, for programs whose records fit uniform buffers (64 KB each,
// vk::classifyUniformFits): brick_classify.comp with the records in uniform buffers, read by
// llvmpipe as vector gathers instead of per-lane loops. The same bound, bit for bit.
#extension GL_GOOGLE_include_directive : require
// Generated bounds (vk/eval/interval_codegen.h) leave loops by subgroup votes.
#extension GL_KHR_shader_subgroup_vote : require
#include "program_layout.h"

// Each block is 64 KB (the host binds buffers of that size, the records at their start).
layout(std140, set = 0, binding = 0) uniform ProgramCode { Instruction programCode[4096]; };
layout(std140, set = 0, binding = 1) uniform ProgramPrims { PrimitiveRecord programPrims[1024]; };
layout(std140, set = 0, binding = 2) uniform ProgramMatrices { MatrixRecord programMatrices[1365]; };
layout(std140, set = 0, binding = 3) uniform ProgramBoxes { BoxRecord programBoxes[2048]; };
layout(std140, set = 0, binding = 4) uniform ProgramWarps { WarpRecord programWarps[2048]; };

#include "brick_classify_body.glsl"
