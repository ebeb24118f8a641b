// The specialised evaluator with shared functions: each shape that repeats in a run of siblings
// (vk/eval/program_shape.h) becomes one GLSL function, called in a loop over its instances' record
// values, which the kernel reads from the program's code buffer after the instructions.
// Internal to vk/eval/program_codegen.cpp.
#pragma once

#include "blobvk/blobtree/program.h"
#include "blobvk/vk/eval/program_codegen.h"
#include "blobvk/vk/eval/program_shape.h"

#include <cstdint>
#include <string>

namespace blobvk::vk {

// evaluateField and evaluateFieldColour (and the functions they call) for `program`, analysed
// with options.loops; `emitted` receives the instructions the text spells out (a function's
// once, however often it is called).
std::string generateLoopedEvaluators(const blobtree::Program& program, const CodeShapes& shapes,
                                     const CodegenOptions& options, std::uint32_t* emitted);

}  // namespace blobvk::vk
