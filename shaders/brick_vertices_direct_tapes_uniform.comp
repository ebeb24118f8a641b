#version 450
// Sparse extraction, pass 7 over per-brick vertex tapes in uniform blocks: brick_vertices_direct_tapes.comp
// run per window of bricks (vk/extract/brick_tapes.h, UniformTapes with TapeUse::Vertex), a lane
// per entry of the window's vertex list (the host's, vk/extract/vertex_tile_lists.h), the
// window's code and records bound as five blocks of 64 KB. llvmpipe reads a uniform block with a
// vector gather and a storage buffer with a loop over the lanes. The same vertices, bit for bit.
#extension GL_GOOGLE_include_directive : require
#define EDGE_VERTEX_NO_SAMPLES
#define EVALUATOR_GRADIENT_ONLY  // no samples, no stack traversal: evaluateGradient alone (eval_program.glsl)
#define EVAL_TAPES
#define EVAL_RECORDS_UNIFORM
#define BRICK_VERTICES_TILED
#include "brick_vertices_body.glsl"
