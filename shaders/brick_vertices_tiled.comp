#version 450
// Sparse extraction, pass 7 per field tile (brick_tiles.h): brick_vertices.comp over the vertices of
// one tile's bricks (brick_vertex_tile_lists.comp), dispatched indirectly, with the evaluator pruned
// to the tile's box of bricks. Each vertex lies on an edge between two points of its brick, inside
// that box, so the pruned code gives its value, gradient and colour bit for bit.
#extension GL_GOOGLE_include_directive : require
#define BRICK_VERTICES_TILED
#include "brick_vertices_body.glsl"
