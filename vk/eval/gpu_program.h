// A Program uploaded to device buffers (the five record arrays of shaders/program_layout.h),
// bound at five consecutive bindings by every evaluating kernel.
#pragma once

#include "blobvk/blobtree/program.h"
#include "blobvk/vk/device/context.h"
#include "blobvk/vk/eval/program_codegen.h"

#include <array>
#include <cstdint>
#include <memory>
#include <string>

namespace blobvk::vk {

enum class Traversal {
  Stackless,   // the compiled register code with box skips (the thesis' stackless traversal)
  StackBased,  // a tree walk with an explicit node stack (Table 4.2's comparison)
  // The stackless register code compiled into the kernel itself (vk/eval/program_codegen.h): one
  // pipeline per program, built at run time; programs too large for it use Stackless.
  Specialised,
  // Chosen per job by the cost model (vk/eval/evaluator_choice.h): Stackless or Specialised, as one
  // kernel or per field tile. Resolved by evaluateFieldOnGrid and the polygonizers; a kernel
  // asked for with Auto unresolved (the ray-caster) interprets.
  Auto,
};

// "stackless", "stack-based", "specialised", "auto".
const char* traversalName(Traversal traversal);

struct GpuProgram {
  Buffer code, primitives, matrices, boxes, warps;
  std::uint32_t codeLength = 0;
  // What the program uses, for the evaluator's specialization constants 2-5 (see
  // shaders/eval_program.glsl): the shader drops every opcode, primitive and warp type it lacks.
  std::uint32_t fieldRegisters = layout::MAX_FIELD_REGISTERS;
  std::uint32_t opMask = ~0u, primitiveMask = ~0u, warpMask = ~0u;
  // Traversal::Specialised: the options evaluators are generated with, and the program when it
  // can be specialised whole (else null: kernels run the stackless interpreter, except field
  // tiles small enough to specialise, vk/eval/field.h). A source is generated only when a kernel
  // with this evaluator is not yet on the device.
  CodegenOptions codegen;
  std::shared_ptr<const blobtree::Program> specialised;
  std::uint64_t fingerprint = 0;  // programFingerprint of the uploaded program (Specialised)
  // The box record after the program's that holds no point (region_tape.h, emptySkipBox): the
  // "write 0" of per-brick tapes tests it.
  std::uint32_t emptyBox = 0;

  // Specialization constants 0-5 of every kernel that includes eval_program.glsl.
  std::array<std::uint32_t, 6> specs(std::uint32_t workgroupSize, Traversal traversal) const {
    return {workgroupSize, traversal == Traversal::StackBased ? 1u : 0u, fieldRegisters, opMask,
            primitiveMask, warpMask};
  }
  // The five bindings in shader order.
  std::array<BufferRange, 5> bindings() const {
    return {BufferRange(code), BufferRange(primitives), BufferRange(matrices), BufferRange(boxes),
            BufferRange(warps)};
  }
};

// The pipeline of an evaluating kernel (an embedded shaders/<shader>.comp that includes
// eval_program.glsl) for this program and traversal: for Traversal::Specialised the kernel is
// compiled at run time with the program's generated evaluator (once per device and program).
KernelPtr evaluatorKernel(Device& device, const GpuProgram& program, const std::string& shader,
                          std::uint32_t workgroupSize, Traversal traversal);

// The pipeline of an evaluating kernel compiled at run time with the evaluator generated for
// `program` and `codegen` (vk/eval/program_codegen.h) in place of eval_program.glsl: generated and
// compiled once per device, then found by its fingerprint.
KernelPtr specialisedKernel(Device& device, const blobtree::Program& program, const CodegenOptions& codegen,
                            const std::string& shader, std::uint32_t workgroupSize);
// The same with the program's fingerprint already computed (programFingerprint).
KernelPtr specialisedKernel(Device& device, const blobtree::Program& program, std::uint64_t programFingerprint,
                            const CodegenOptions& codegen, const std::string& shader, std::uint32_t workgroupSize);

// Whether `device` already holds the kernel specialisedKernel would build (nothing is generated),
// or the interpreter kernel evaluatorKernel would use for `program` (Traversal::Stackless).
bool specialisedKernelBuilt(Device& device, std::uint64_t programFingerprint, const CodegenOptions& codegen,
                            const std::string& shader, std::uint32_t workgroupSize);
bool interpreterKernelBuilt(Device& device, const blobtree::Program& program, const std::string& shader,
                            std::uint32_t workgroupSize);

// Code generation options for this device: on GPUs branches on skips and loops over repeated
// shapes; on CPU drivers masked skips, and loops only in long programs (whose looped code
// branches).
CodegenOptions defaultCodegenOptions(const Device& device);
CodegenOptions defaultCodegenOptions(bool cpuDevice);

// Uploads the records; Traversal::StackBased uploads the tree encoding (stack_program.h) in
// place of the register code. Throws std::invalid_argument for a Program over the register
// limits of the layout.
// For Traversal::Specialised the evaluator is generated here, with `codegen` when given, else
// with branches on skips except on CPU devices (vk/eval/program_codegen.h).
GpuProgram uploadProgram(Device& device, const blobtree::Program& program,
                         Traversal traversal = Traversal::Stackless, const CodegenOptions* codegen = nullptr);

}  // namespace blobvk::vk
