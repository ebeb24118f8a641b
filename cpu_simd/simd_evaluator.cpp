// Run-time dispatch of the batch evaluators (see simd_evaluator.h). The ISA kernels live in
// simd_avx2.cpp / simd_avx512.cpp; this file is compiled for baseline x86-64 and only calls them
// after __builtin_cpu_supports says the CPU has the instructions.
#include "blobvk/cpu_simd/simd_evaluator.h"

#include "blobvk/blobtree/evaluate.h"
#include "blobvk/blobtree/gradient.h"
#include "blobvk/cpu_simd/simd_kernels.h"

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

namespace blobvk::cpu {
namespace {

SimdLevel detectLevel() {
#if defined(__x86_64__) || defined(__i386__)
  __builtin_cpu_init();
  SimdLevel level = SimdLevel::Scalar;
  if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma")) level = SimdLevel::Avx2;
  if (level == SimdLevel::Avx2 && __builtin_cpu_supports("avx512f") &&
      __builtin_cpu_supports("avx512dq"))
    level = SimdLevel::Avx512;
  return level;
#else
  return SimdLevel::Scalar;
#endif
}

SimdLevel cpuLevel() {
  static const SimdLevel level = detectLevel();
  return level;
}

void checkSupported(SimdLevel level) {
  if (!simdLevelSupported(level))
    throw std::invalid_argument(std::string("SIMD level ") + toString(level) +
                                " is not supported by this CPU");
}

void scalarBatch(const blobtree::Program& program, const float* x, const float* y, const float* z,
                 float* field, float* r, float* g, float* b, std::size_t n) {
  for (std::size_t i = 0; i < n; ++i) {
    const glm::vec3 p(x[i], y[i], z[i]);
    if (r) {
      const blobtree::FieldColour fc = blobtree::evaluateWithColour(program, p);
      field[i] = fc.field, r[i] = fc.colour.x, g[i] = fc.colour.y, b[i] = fc.colour.z;
    } else {
      field[i] = blobtree::evaluate(program, p);
    }
  }
}

void dispatch(const blobtree::Program& program, const float* x, const float* y, const float* z,
              float* field, float* r, float* g, float* b, std::size_t n, SimdLevel level) {
  switch (level) {
    case SimdLevel::Avx512:
      checkSupported(level);
      detail::evaluateAvx512(program, x, y, z, field, r, g, b, n);
      return;
    case SimdLevel::Avx2:
      checkSupported(level);
      detail::evaluateAvx2(program, x, y, z, field, r, g, b, n);
      return;
    case SimdLevel::Scalar:
      scalarBatch(program, x, y, z, field, r, g, b, n);
      return;
  }
}

}  // namespace

bool simdLevelSupported(SimdLevel level) { return int(level) <= int(cpuLevel()); }

SimdLevel bestSimdLevel() {
  SimdLevel level = cpuLevel();
  if (const char* cap = std::getenv("BLOBVK_SIMD")) {
    SimdLevel wanted = level;
    if (std::strcmp(cap, "scalar") == 0) wanted = SimdLevel::Scalar;
    if (std::strcmp(cap, "avx2") == 0) wanted = SimdLevel::Avx2;
    if (std::strcmp(cap, "avx512") == 0) wanted = SimdLevel::Avx512;
    if (int(wanted) < int(level)) level = wanted;
  }
  return level;
}

int simdWidth(SimdLevel level) {
  return level == SimdLevel::Avx512 ? 16 : level == SimdLevel::Avx2 ? 8 : 1;
}

const char* toString(SimdLevel level) {
  switch (level) {
    case SimdLevel::Scalar: return "scalar";
    case SimdLevel::Avx2: return "avx2";
    case SimdLevel::Avx512: return "avx512";
  }
  return "?";
}

void evaluateFieldBatch(const blobtree::Program& program, const float* x, const float* y,
                        const float* z, float* field, std::size_t n, SimdLevel level) {
  dispatch(program, x, y, z, field, nullptr, nullptr, nullptr, n, level);
}

void evaluateFieldColourBatch(const blobtree::Program& program, const float* x, const float* y,
                              const float* z, float* field, float* r, float* g, float* b,
                              std::size_t n, SimdLevel level) {
  dispatch(program, x, y, z, field, r, g, b, n, level);
}

void evaluateGradientBatch(const blobtree::Program& program, const float* x, const float* y,
                           const float* z, float* field, float* gx, float* gy, float* gz, float* r,
                           float* g, float* b, std::size_t n, SimdLevel level) {
  float* const outputs[7] = {field, gx, gy, gz, r, g, b};
  const bool colour = r != nullptr;
  switch (level) {
    case SimdLevel::Avx512:
      checkSupported(level);
      detail::gradientAvx512(program, x, y, z, outputs, colour, n);
      return;
    case SimdLevel::Avx2:
      checkSupported(level);
      detail::gradientAvx2(program, x, y, z, outputs, colour, n);
      return;
    case SimdLevel::Scalar:
      for (std::size_t i = 0; i < n; ++i) {
        const glm::vec3 p(x[i], y[i], z[i]);
        const blobtree::FieldGradient fg =
            colour ? blobtree::evaluateGradientColour(program, p) : blobtree::evaluateGradient(program, p);
        field[i] = fg.field, gx[i] = fg.gradient.x, gy[i] = fg.gradient.y, gz[i] = fg.gradient.z;
        if (colour) r[i] = fg.colour.x, g[i] = fg.colour.y, b[i] = fg.colour.z;
      }
      return;
  }
}

void evaluateNormalBatch(const blobtree::Program& program, const float* x, const float* y,
                         const float* z, float* nx, float* ny, float* nz, std::size_t n, float h,
                         SimdLevel level) {
  thread_local std::vector<float> shifted, plus, minus;
  shifted.resize(n), plus.resize(n), minus.resize(n);
  const float* axes[3] = {x, y, z};
  float* out[3] = {nx, ny, nz};
  const float inv = 0.5f / h;
  for (int axis = 0; axis < 3; ++axis) {
    // p + vec3(h, 0, 0) changes only this axis' coordinate; the others stay bit-identical.
    const float* in[3] = {x, y, z};
    in[axis] = shifted.data();
    for (std::size_t i = 0; i < n; ++i) shifted[i] = axes[axis][i] + h;
    evaluateFieldBatch(program, in[0], in[1], in[2], plus.data(), n, level);
    for (std::size_t i = 0; i < n; ++i) shifted[i] = axes[axis][i] - h;
    evaluateFieldBatch(program, in[0], in[1], in[2], minus.data(), n, level);
    for (std::size_t i = 0; i < n; ++i) out[axis][i] = (plus[i] - minus[i]) * inv;
  }
  for (std::size_t i = 0; i < n; ++i) {
    const float gx = nx[i], gy = ny[i], gz = nz[i];
    const float len = std::sqrt(gx * gx + gy * gy + gz * gz);
    if (len > 0.0f) {
      nx[i] = -gx / len, ny[i] = -gy / len, nz[i] = -gz / len;
    } else {
      nx[i] = 0.0f, ny[i] = 0.0f, nz[i] = 1.0f;
    }
  }
}

}  // namespace blobvk::cpu
