#version 450
// Sparse extraction, pass 7: one invocation per vertex of the batch, in global edge-key order.
// brick_sources.comp wrote where vertex v comes from: its brick, row of points, point and axis.
// The vertex itself: edge_vertex.glsl. Its edge key (global point index * 3 + axis) is written as
// two words, low first.
// With refinement steps or the stack-based traversal (central-difference normals): the field
// evaluator in the sample loop of edge_vertex.glsl; brick_vertices_direct.comp otherwise.
#extension GL_GOOGLE_include_directive : require
#include "brick_vertices_body.glsl"
