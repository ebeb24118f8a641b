#include "blobvk/vk/extract/classify_kernel.h"

#include "blobvk/vk/device/cache_file_bytes.h"
#include "blobvk/vk/eval/evaluator_costs.h"
#include "blobvk/vk/eval/interval_codegen.h"
#include "blobvk/vk/eval/spirv_cache.h"

#include <algorithm>
#include <array>
#include <string>

namespace blobvk::vk {
namespace {

// The generated kernel is brick_classify_uniform.comp with brick_classify_bounds.glsl replaced:
// the same layout, bindings and specialization constants as the interpreter's.
constexpr const char* kUniformShader = "brick_classify_uniform";

std::string generatedName(const blobtree::Program& program) {
  return std::string(kUniformShader) + ":generated:" + detail::hexDigits(intervalBoundsFingerprint(program), 16);
}

KernelPtr buildGenerated(Device& device, const blobtree::Program& program, const std::string& name,
                         std::span<const std::uint32_t> specs) {
  if (KernelPtr k = device.findKernel(name, specs)) return k;
  const auto code = compileComputeShaderCached(device.spirvCacheDir(), std::string(kUniformShader) + ".comp",
                                               {{"brick_classify_bounds.glsl", generateIntervalBounds(program)}});
  return device.kernel(name, code, kUniformShader, specs);
}

}  // namespace

ClassifyWork classifyWork(const blobtree::Program& program, const blobtree::GridSpec& grid, std::uint32_t brickCells,
                          std::uint32_t maxVectors) {
  return classifyWork(program, program.code, grid, brickCells, maxVectors);
}

ClassifyWork classifyWork(const blobtree::Program& program, std::span<const layout::Instruction> code,
                          const blobtree::GridSpec& grid, std::uint32_t brickCells, std::uint32_t maxVectors) {
  using namespace layout;
  const std::uint32_t B = std::max(brickCells, 1u);
  const std::uint32_t nx = (std::uint32_t(grid.cells.x) + B - 1) / B, ny = (std::uint32_t(grid.cells.y) + B - 1) / B,
                      nz = (std::uint32_t(grid.cells.z) + B - 1) / B;
  const std::uint64_t vx = (nx + 3) / 4, vy = (ny + 1) / 2, vectors = vx * vy * nz;
  const std::uint64_t stride = std::max<std::uint64_t>(1, (vectors + maxVectors - 1) / std::max(maxVectors, 1u));
  const std::size_t n = code.size();
  // Whether a skip on the world point misses a box (others: taken as entered, partly).
  auto misses = [&](const Instruction& in, const float lo[3], const float hi[3]) {
    if (in.code.z != 0 || in.code.y >= program.boxes.size()) return false;
    const BoxRecord& b = program.boxes[in.code.y];
    const float slo[3] = {b.lo.x, b.lo.y, b.lo.z}, shi[3] = {b.hi.x, b.hi.y, b.hi.z};
    for (int a = 0; a < 3; ++a)
      if (hi[a] < slo[a] || lo[a] > shi[a]) return true;
    return false;
  };
  auto isSkip = [&](std::size_t at) { return (code[at].code.x & 0xffu) == OP_SKIP && code[at].code.w > at; };
  ClassifyWork w;
  std::uint64_t walked = 0;
  for (std::uint64_t v = 0; v < vectors; v += stride, ++walked) {
    const std::uint32_t z = std::uint32_t(v / (vx * vy)), y0 = std::uint32_t(v / vx % vy) * 2, x0 = std::uint32_t(v % vx) * 4;
    float lo[8][3], hi[8][3];
    int lanes = 0;
    for (std::uint32_t y = y0; y < std::min(y0 + 2, ny); ++y)
      for (std::uint32_t x = x0; x < std::min(x0 + 4, nx); ++x, ++lanes) {
        const std::uint32_t first[3] = {x * B, y * B, z * B};
        const std::uint32_t last[3] = {std::min(first[0] + B, std::uint32_t(grid.cells.x)),
                                       std::min(first[1] + B, std::uint32_t(grid.cells.y)),
                                       std::min(first[2] + B, std::uint32_t(grid.cells.z))};
        for (int a = 0; a < 3; ++a) {
          lo[lanes][a] = grid.origin[a] + grid.cellSize * float(first[a]);
          hi[lanes][a] = grid.origin[a] + grid.cellSize * float(last[a]);
        }
      }
    double longest = 0.0;
    for (int l = 0; l < lanes; ++l) {
      double steps = 0.0;
      for (std::size_t at = 0; at < n; ++steps)
        at = isSkip(at) && misses(code[at], lo[l], hi[l]) ? code[at].code.w : at + 1;
      longest = std::max(longest, steps);
    }
    w.interpreted += longest;
    for (std::size_t at = 0; at < n; w.generated += 1.0) {
      bool all = isSkip(at) && code[at].code.w - at - 1 >= kIntervalBranchInstructions;
      for (int l = 0; l < lanes && all; ++l) all = misses(code[at], lo[l], hi[l]);
      at = all ? code[at].code.w : at + 1;
    }
  }
  const double scale = walked ? double(vectors) / double(walked) : 0.0;
  w.interpreted *= scale;
  w.generated *= scale;
  return w;
}

bool classifyCodePays(const blobtree::Program& program, const blobtree::GridSpec& grid, std::uint32_t brickCells,
                      std::uint32_t runs, double interpretedSeconds) {
  std::size_t skips = 0;
  for (const layout::Instruction& in : program.code) skips += (in.code.x & 0xffu) == layout::OP_SKIP;
  if (skips > costs::kClassifyGeneratedMaxSkips) return false;
  const ClassifyWork w = classifyWork(program, grid, brickCells);
  double interpreted = costs::kClassifyInterpretedSecondsPerStep * w.interpreted;
  if (interpretedSeconds >= 0.0) interpreted = std::min(interpreted, interpretedSeconds);
  const double generated = costs::kClassifyInterpretedSecondsPerStep * costs::kClassifyGeneratedStepCost * w.generated;
  if (generated > costs::kClassifyGeneratedMargin * interpreted) return false;
  const double n = double(program.code.size());
  return (interpreted - generated) * double(runs) >
         costs::kClassifyBuildSecondsPerInstruction * n + costs::kClassifyBuildSecondsPerInstruction2 * n * n;
}

ClassifyKernel classifyKernel(Device& device, const blobtree::Program& program, const GpuProgram& gpu,
                              bool uniformRecords, const ClassifyChoice& choice, const blobtree::GridSpec& grid,
                              std::uint32_t brickCells) {
  // Constants 3-5: the program's opcode, primitive and warp masks (the others are not used).
  const auto specs = gpu.specs(64, Traversal::Stackless);
  auto interpreter = [&] {
    return ClassifyKernel{device.kernel(uniformRecords ? kUniformShader : "brick_classify", specs), false};
  };
  if (!uniformRecords || choice.code == ClassifyCode::Interpreter || !canGenerateIntervalBounds(program))
    return interpreter();
  const std::string name = generatedName(program);
  if (choice.code == ClassifyCode::Generated) {
    device.waitForBackgroundBuild(name);  // an earlier job's: then found here
    return {buildGenerated(device, program, name, specs), true};
  }
  if (KernelPtr k = device.findKernel(name, specs)) {
    // Built by an earlier job's cost model; the interpreter's tiles may still be faster here.
    if (choice.tiledSeconds < 0.0) return {k, true};
    const ClassifyWork w = classifyWork(program, grid, brickCells, 256);
    const double generated = costs::kClassifyInterpretedSecondsPerStep * costs::kClassifyGeneratedStepCost * w.generated;
    return generated < choice.tiledSeconds ? ClassifyKernel{k, true} : interpreter();
  }
  // This job interprets (the build would delay it by more than it saves on one run: random128 at
  // 512 cells classifies in 0.1-0.2 s, its generated kernel builds in 8 s of CPU); later jobs take
  // the generated kernel once it is built, where the cost model expects enough of them.
  if (choice.expectedRuns > 1 && !device.backgroundBuildStarted(name) &&
      classifyCodePays(program, grid, brickCells, choice.expectedRuns - 1, choice.tiledSeconds)) {
    device.buildInBackground(name, [&d = device, program = blobtree::Program(program), name,
                                    s = std::array<std::uint32_t, 6>(specs)] { buildGenerated(d, program, name, s); });
  }
  return interpreter();
}

}  // namespace blobvk::vk
