// The GLSL text of every shaders/*.comp, *.glsl and *.h, embedded at build time
// (cmake/embed_shader_sources.cmake), for kernels compiled at run time (vk/eval/runtime_compiler.h).
#pragma once

#include <cstdint>
#include <optional>
#include <string_view>

namespace blobvk::vk {

// Text of the source file named `fileName` ("field_grid.comp", "eval_formulas.glsl").
std::optional<std::string_view> shaderSource(std::string_view fileName);

// A 64-bit hash of every embedded source's name and text (computed once): kernels compiled at
// run time depend on them through their includes, so caches of their SPIR-V key on it.
std::uint64_t shaderSourcesFingerprint();

}  // namespace blobvk::vk
