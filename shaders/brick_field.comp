#version 450
// Sparse extraction, pass 3: the field at the points of every active brick and the inside bits
// per row of points (brick_field_body.glsl), with the whole program (interpreted or generated).
#extension GL_GOOGLE_include_directive : require
#include "brick_field_body.glsl"
