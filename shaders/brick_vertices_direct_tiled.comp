#version 450
// Sparse extraction, pass 7 per field tile: brick_vertices_direct.comp (no samples, the normal from
// the gradient) over one tile's vertices, as brick_vertices_tiled.comp.
#extension GL_GOOGLE_include_directive : require
#define EDGE_VERTEX_NO_SAMPLES
#define EVALUATOR_GRADIENT_ONLY  // no samples, no stack traversal: evaluateGradient alone (eval_program.glsl)
#define BRICK_VERTICES_TILED
#include "brick_vertices_body.glsl"
