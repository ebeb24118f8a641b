#version 450
// Sparse extraction, pass 3 with row culling (vk/extract/row_culling.h): brick_field.comp over the
// listed rows of the batch's bricks only, one lane per row; brick_row_fill.comp sets the inside
// bits of the others.
#extension GL_GOOGLE_include_directive : require
#define FIELD_ROW_LIST
#include "brick_field_body.glsl"
