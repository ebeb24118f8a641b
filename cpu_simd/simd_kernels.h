// Internal: the per-ISA entry points behind simd_evaluator.h. Each is defined in a file compiled
// with that ISA's flags (simd_avx2.cpp, simd_avx512.cpp) and must only be called after the CPU
// check in simd_evaluator.cpp. Colour pointers may be null (field only).
#pragma once

#include "blobvk/blobtree/program.h"

#include <cstddef>

namespace blobvk::cpu::detail {

void evaluateAvx2(const blobtree::Program& program, const float* x, const float* y, const float* z,
                  float* field, float* r, float* g, float* b, std::size_t n);
void evaluateAvx512(const blobtree::Program& program, const float* x, const float* y,
                    const float* z, float* field, float* r, float* g, float* b, std::size_t n);

// Field, gradient x, y, z and (colour) r, g, b into outputs[0..3] (and [4..6]), per point.
void gradientAvx2(const blobtree::Program& program, const float* x, const float* y, const float* z,
                  float* const* outputs, bool colour, std::size_t n);
void gradientAvx512(const blobtree::Program& program, const float* x, const float* y, const float* z,
                    float* const* outputs, bool colour, std::size_t n);

}  // namespace blobvk::cpu::detail
