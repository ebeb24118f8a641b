#version 450
// Sparse extraction, pass 7 interpreting the gradient from uniform blocks: brick_vertices_direct.comp
// with the program's code and records in five uniform blocks of 64 KB (vk/extract/uniform_program.h),
// for a program that fits them. llvmpipe reads a uniform block with a vector gather and a storage
// buffer with a loop over the lanes, so the interpreted vertex pass, the one a first job runs while
// no generated gradient is built, runs several times faster. The same vertices, bit for bit.
#extension GL_GOOGLE_include_directive : require
#define EDGE_VERTEX_NO_SAMPLES
#define EVALUATOR_GRADIENT_ONLY  // no samples, no stack traversal: evaluateGradient alone (eval_program.glsl)
#define EVAL_RECORDS_UNIFORM
#include "brick_vertices_body.glsl"
