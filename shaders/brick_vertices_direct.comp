#version 450
// Sparse extraction, pass 7, without refinement steps and with the normal from the gradient (every
// traversal but the stack-based one): brick_vertices.comp without edge_vertex.glsl's sample loop.
// llvmpipe runs a loop's body at least once under a lane mask, so the loop's field evaluator cost
// a whole evaluation per vertex even with no sample to take, and its code doubled the kernel's
// JIT time. The same vertices, bit for bit (the loop takes no sample then).
#extension GL_GOOGLE_include_directive : require
#define EDGE_VERTEX_NO_SAMPLES
#define EVALUATOR_GRADIENT_ONLY  // no samples, no stack traversal: evaluateGradient alone (eval_program.glsl)
#include "brick_vertices_body.glsl"
