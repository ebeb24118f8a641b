#include "blobvk/vk/eval/gpu_program.h"

#include "blobvk/vk/eval/evaluator_costs.h"
#include "blobvk/vk/eval/program_codegen.h"
#include "blobvk/vk/eval/region_tape.h"
#include "blobvk/vk/eval/spirv_cache.h"
#include "blobvk/vk/eval/stack_program.h"

#include <algorithm>
#include <cstdio>
#include <functional>
#include <stdexcept>
#include <string>

namespace blobvk::vk {
namespace {
constexpr std::uint32_t kMaskHasMatrix = 0x80000000u;  // MASK_HAS_MATRIX in eval_program.glsl

template <class T>
Buffer uploadArray(Device& device, const std::vector<T>& v) {
  Buffer b = device.createBuffer(std::max<std::size_t>(v.size(), 1) * sizeof(T));
  device.upload(b, v.data(), v.size() * sizeof(T));
  return b;
}
// Masks describe the register code, which the stack encoding is rebuilt from: both
// traversals meet the same primitive and warp types.
void setEvaluatorMasks(const blobtree::Program& program, GpuProgram& g) {
  g.fieldRegisters = std::max<std::uint32_t>(program.fieldRegisters, 1);
  g.opMask = 0;
  for (const auto& in : program.code) g.opMask |= 1u << (in.code.x & 0x1fu);
  g.primitiveMask = 0;
  for (const auto& prim : program.primitives) {
    g.primitiveMask |= 1u << (prim.meta.x & 0x1fu);
    if (prim.meta.y != 0) g.primitiveMask |= kMaskHasMatrix;
  }
  g.warpMask = 0;
  for (const auto& warp : program.warps) {
    g.warpMask |= 1u << (warp.meta.x & 0x1fu);
    if (warp.meta.w != 0) g.warpMask |= kMaskHasMatrix;
  }
}

// Pipelines of generated code are cached under the shader's name and the evaluator's fingerprint.
std::string specialisedKernelName(std::uint64_t fingerprint, const CodegenOptions& codegen, const std::string& shader) {
  char key[17];
  std::snprintf(key, sizeof key, "%016llx", static_cast<unsigned long long>(evaluatorFingerprint(fingerprint, codegen)));
  return shader + "/specialised:" + key;
}

}  // namespace

const char* traversalName(Traversal traversal) {
  switch (traversal) {
    case Traversal::Stackless: return "stackless";
    case Traversal::StackBased: return "stack-based";
    case Traversal::Specialised: return "specialised";
    case Traversal::Auto: return "auto";
  }
  return "?";
}

GpuProgram uploadProgram(Device& device, const blobtree::Program& program, Traversal traversal,
                         const CodegenOptions* codegenOverride) {
  if (program.fieldRegisters > layout::MAX_FIELD_REGISTERS ||
      program.pointRegisters > layout::MAX_POINT_REGISTERS) {
    throw std::invalid_argument("Program needs " + std::to_string(program.fieldRegisters) +
                                " field and " + std::to_string(program.pointRegisters) +
                                " point registers, above the shader's register file");
  }
  GpuProgram g;
  if (traversal == Traversal::StackBased) {
    const auto tree = buildStackProgram(program);
    g.code = uploadArray(device, tree);
    g.codeLength = std::uint32_t(tree.size());
  } else if (traversal == Traversal::Specialised) {
    // The instructions (for kernels that interpret), then the record words the generated loops
    // read (vk/eval/program_codegen.h).
    g.codegen = codegenOverride ? *codegenOverride : defaultCodegenOptions(device);
    std::vector<layout::Instruction> words = program.code;
    for (const layout::uvec4& w : specialisedData(program, g.codegen.loops)) words.push_back({w});
    g.code = uploadArray(device, words);
    g.codeLength = std::uint32_t(program.code.size());
  } else {
    g.code = uploadArray(device, program.code);
    g.codeLength = std::uint32_t(program.code.size());
  }
  setEvaluatorMasks(program, g);
  if (traversal == Traversal::Specialised) {
    g.fingerprint = programFingerprint(program);
    if (canSpecialise(program, {}, g.codegen.loops)) g.specialised = std::make_shared<const blobtree::Program>(program);
  }
  g.primitives = uploadArray(device, program.primitives);
  g.matrices = uploadArray(device, program.matrices);
  std::vector<layout::BoxRecord> boxes = program.boxes;
  g.emptyBox = std::uint32_t(boxes.size());
  boxes.push_back(emptySkipBox());
  g.boxes = uploadArray(device, boxes);
  g.warps = uploadArray(device, program.warps);
  return g;
}

KernelPtr evaluatorKernel(Device& device, const GpuProgram& program, const std::string& shader,
                          std::uint32_t workgroupSize, Traversal traversal) {
  if (traversal != Traversal::Specialised || !program.specialised)
    return device.kernel(shader, program.specs(workgroupSize, traversal == Traversal::StackBased
                                                                            ? Traversal::StackBased
                                                                            : Traversal::Stackless));
  return specialisedKernel(device, *program.specialised, program.fingerprint, program.codegen, shader, workgroupSize);
}

KernelPtr specialisedKernel(Device& device, const blobtree::Program& program, const CodegenOptions& codegen,
                            const std::string& shader, std::uint32_t workgroupSize) {
  return specialisedKernel(device, program, programFingerprint(program), codegen, shader, workgroupSize);
}

KernelPtr specialisedKernel(Device& device, const blobtree::Program& program, std::uint64_t fingerprint,
                            const CodegenOptions& codegen, const std::string& shader, std::uint32_t workgroupSize) {
  // Only the workgroup size (constant 0) matters to the generated evaluator.
  const std::array<std::uint32_t, 1> specs{workgroupSize};
  const std::string name = specialisedKernelName(fingerprint, codegen, shader);
  if (KernelPtr k = device.findKernel(name, specs)) return k;
  const auto code = compileComputeShaderCached(
      device.spirvCacheDir(), shader + ".comp", {{"eval_program.glsl", generateSpecialisedEvaluator(program, codegen)}});
  return device.kernel(name, code, shader, specs);
}

bool specialisedKernelBuilt(Device& device, std::uint64_t fingerprint, const CodegenOptions& codegen,
                            const std::string& shader, std::uint32_t workgroupSize) {
  const std::array<std::uint32_t, 1> specs{workgroupSize};
  return device.findKernel(specialisedKernelName(fingerprint, codegen, shader), specs) != nullptr;
}

bool interpreterKernelBuilt(Device& device, const blobtree::Program& program, const std::string& shader,
                            std::uint32_t workgroupSize) {
  GpuProgram g;
  setEvaluatorMasks(program, g);
  return device.findKernel(shader, g.specs(workgroupSize, Traversal::Stackless)) != nullptr;
}

CodegenOptions defaultCodegenOptions(bool cpuDevice) {
  CodegenOptions c;
  // llvmpipe runs both sides of a branch and pays for subgroup votes: short unrolled code runs
  // faster masked (its skips always run, outside lanes get 0).
  c.branchOnSkips = !cpuDevice;
  // llvmpipe turns each buffer load inside a loop into a loop over the lanes: looped code runs
  // tens of times slower there than unrolled code, so CPU drivers unroll all but long programs,
  // whose unrolled build would outweigh the job (vk/eval/evaluator_costs.h).
  if (cpuDevice) c.loops.minProgramInstructions = costs::kLoopedAboveInstructionsOnCpu;
  return c;
}

CodegenOptions defaultCodegenOptions(const Device& device) {
  return defaultCodegenOptions(device.info().type == VK_PHYSICAL_DEVICE_TYPE_CPU);
}

}  // namespace blobvk::vk
