// GLSL -> SPIR-V at run time (libshaderc), for kernels whose source depends on the data: the
// specialised evaluator (vk/eval/program_codegen.h) replaces shaders/eval_program.glsl in an embedded
// kernel's include graph. Build-time shaders do not go through here.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace blobvk::vk {

// Compiles the embedded compute shader `shaderFile` ("field_grid.comp") to SPIR-V for Vulkan 1.1,
// resolving #include "x" from `overrides` first, then from the embedded sources. Throws
// VulkanError with glslang's messages on failure.
std::vector<std::uint32_t> compileComputeShader(const std::string& shaderFile,
                                                const std::map<std::string, std::string>& overrides);

// How many times this process has initialised glslang (0 before the first compile, then 1 for
// good: initialised once, never finalised, whatever the threads).
std::uint32_t glslangInitialisations();

}  // namespace blobvk::vk
