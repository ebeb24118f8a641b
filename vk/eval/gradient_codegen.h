// The specialised gradient: a compiled Program's analytic gradient (field, gradient and colour in
// one pass, blobtree::evaluateGradientColour) as straight-line GLSL, generated alongside the
// specialised field evaluator (program_codegen.h) for the vertex kernels' normals.
//
// Why: the vertex pass computes each vertex's normal from the analytic gradient. Interpreted
// (shaders/eval_gradient.glsl) it pays, per instruction and lane, for loading the instruction
// and records and selecting registers by index, which on lavapipe made the vertex pass the
// largest phase of a specialised mesh. The generated code calls the formulas the interpreter
// calls (shaders/eval_gradient_formulas.glsl) in the same order, with opcodes, registers and
// primitive types fixed in the code, so the normals are the interpreter's bit for bit.
#pragma once

#include "blobvk/blobtree/program.h"
#include "blobvk/vk/eval/program_codegen.h"

#include <cstdint>
#include <string>

namespace blobvk::vk {

// GLSL that defines BLOBVK_GENERATED_GRADIENT and
//   precise float evaluateGradient(vec3 p, uint n, bool wantColour, out vec3 gradient, out vec3 colour)
// (n ignored), to follow the unrolled field evaluator, whose instruction-buffer view `codeArray`
// it reads OP_POW's exponents from (as the field code does: a literal exponent lets NIR rewrite
// pow). Skips whose box misses options.region have no code (the interpreter writes 0 there too),
// nor primitives whose support box misses it (their outside values, +0, with loaded zeros);
// skips branch or run masked as options.branchOnSkips says. Record values are literals except
// zeros, which are loaded (NIR folds x * 0.0 + y into y, which can change the sign of a zero).
// Empty when the program's matrices[0] is not the identity (the vertex kernels then interpret).
// Throws std::invalid_argument on malformed code (as generateSpecialisedEvaluator).
std::string generateSpecialisedGradient(const blobtree::Program& program, const CodegenOptions& options,
                                        const char* codeArray);

}  // namespace blobvk::vk
