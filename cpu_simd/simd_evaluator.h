// SIMD evaluation of a compiled Program over batches of points (structure of arrays), chosen at
// run time: AVX-512 (16 lanes), AVX2 (8 lanes) or a scalar loop over blobtree::evaluate. The SIMD
// kernels repeat the scalar reference's float operations in the same order (no FMA contraction),
// so their fields equal the reference's bit for bit (warps and Ricci powers call the same libm
// functions per lane). This header carries no intrinsics: any translation unit may include it.
#pragma once

#include "blobvk/blobtree/program.h"

#include <cstddef>

namespace blobvk::cpu {

enum class SimdLevel { Scalar = 0, Avx2 = 1, Avx512 = 2 };

// The widest level this CPU runs (BLOBVK_SIMD=scalar|avx2|avx512 in the environment caps it).
SimdLevel bestSimdLevel();
bool simdLevelSupported(SimdLevel level);
int simdWidth(SimdLevel level);  // 1, 8 or 16
const char* toString(SimdLevel level);

// field[i] = evaluate(program, (x[i], y[i], z[i])) for i < n.
void evaluateFieldBatch(const blobtree::Program& program, const float* x, const float* y,
                        const float* z, float* field, std::size_t n, SimdLevel level);

// Field and colour (r, g, b per point) as blobtree::evaluateWithColour.
void evaluateFieldColourBatch(const blobtree::Program& program, const float* x, const float* y,
                              const float* z, float* field, float* r, float* g, float* b,
                              std::size_t n, SimdLevel level);

// Field and analytic gradient (gx, gy, gz) per point, and the colour when r is not null, as
// blobtree::evaluateGradient / evaluateGradientColour, bit for bit: one pass per point.
void evaluateGradientBatch(const blobtree::Program& program, const float* x, const float* y,
                           const float* z, float* field, float* gx, float* gy, float* gz, float* r,
                           float* g, float* b, std::size_t n, SimdLevel level);

// Outward unit normals as blobtree::normal(program, p, h): central differences, 6 evaluations per
// point done as 6 SIMD batches.
void evaluateNormalBatch(const blobtree::Program& program, const float* x, const float* y,
                         const float* z, float* nx, float* ny, float* nz, std::size_t n, float h,
                         SimdLevel level);

}  // namespace blobvk::cpu
