// Specialization constants 3-5 of the evaluators (vk::GpuProgram::specs): the opcodes, primitive
// types and warp types the program has. llvmpipe runs every branch of an interpreter loop under
// a lane mask, so what a program lacks must fold away. Shared by the field interpreter
// (eval_program.glsl) and the brick classification (brick_classify_body.glsl).
#ifndef BLOBVK_PROGRAM_MASKS_GLSL
#define BLOBVK_PROGRAM_MASKS_GLSL
layout(constant_id = 3) const uint OP_MASK = 0xffffffffu;
layout(constant_id = 4) const uint PRIM_MASK = 0xffffffffu;
layout(constant_id = 5) const uint WARP_MASK = 0xffffffffu;
#define HAS_OP(op) ((OP_MASK & (1u << (op))) != 0u)
#define HAS_PRIM(t) ((PRIM_MASK & (1u << (t))) != 0u)
#define HAS_WARP(t) ((WARP_MASK & (1u << (t))) != 0u)
const uint MASK_HAS_MATRIX = 0x80000000u;
#endif
