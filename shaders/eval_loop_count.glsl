// llvmpipe ends every loop of a shader invocation once they have run 65,535 iterations in all
// (vk/extract/loop_limit.h). A kernel that defines EVAL_COUNT_LOOPS before including the
// evaluator counts every iteration of the evaluator's loops (the interpreters' instructions and
// tree steps, the generated code's branching skips and instance loops) and ticks its own loops
// too, in evalLoopIterations, so that it can stop short of the limit and say so. Elsewhere
// EVAL_LOOP_TICK() is nothing.
#ifndef BLOBVK_EVAL_LOOP_COUNT_GLSL
#define BLOBVK_EVAL_LOOP_COUNT_GLSL
#ifdef EVAL_COUNT_LOOPS
uint evalLoopIterations = 0u;
#define EVAL_LOOP_TICK() (++evalLoopIterations)
#else
#define EVAL_LOOP_TICK()
#endif
#endif
