#version 450
// Sparse extraction, pass 3 with per-brick tapes: brick_field.comp whose interpreter runs, for each
// brick, the program pruned to that brick on the host (vk/eval/region_tape.h, TapeUse::Field).
// Always the interpreter: a tape is data, so no kernel is built per brick.
#extension GL_GOOGLE_include_directive : require
#define EVAL_TAPES
#include "brick_field_body.glsl"
