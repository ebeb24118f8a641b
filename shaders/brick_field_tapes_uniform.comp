#version 450
// Sparse extraction, pass 3 with per-brick tapes whose code and records are in uniform blocks
// (brick_field_tapes.comp's, read by llvmpipe as vector gathers; vk/extract/brick_tapes.h packs
// each window of bricks' tapes with the records they use). The same field, bit for bit.
#extension GL_GOOGLE_include_directive : require
#define EVAL_TAPES
#define EVAL_RECORDS_UNIFORM
#include "brick_field_body.glsl"
