#version 450
// Sparse extraction, pass 7 over per-brick vertex tapes: brick_vertices_direct.comp interpreting
// each vertex's gradient and colour from its brick's tape (vk/extract/brick_tapes.h,
// TapeUse::Vertex: the program pruned to the brick with every bit of the gradient and colour
// kept, a run of primitives that are 0 there one OP_NULL_ADDS) instead of the whole program: a
// flat blend of 600 points runs a few tens of instructions a vertex instead of 1,200. The same
// vertices, bit for bit.
#extension GL_GOOGLE_include_directive : require
#define EDGE_VERTEX_NO_SAMPLES
#define EVALUATOR_GRADIENT_ONLY  // no samples, no stack traversal: evaluateGradient alone (eval_program.glsl)
#define EVAL_TAPES
#include "brick_vertices_body.glsl"
