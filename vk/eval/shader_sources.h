// The GLSL text of every shaders/*.comp, *.glsl and *.h, embedded at build time
// (cmake/embed_shader_sources.cmake), for kernels compiled at run time (vk/eval/runtime_compiler.h).
#pragma once

#include <optional>
#include <string_view>

namespace blobvk::vk {

// Text of the source file named `fileName` ("field_grid.comp", "eval_formulas.glsl").
std::optional<std::string_view> shaderSource(std::string_view fileName);

}  // namespace blobvk::vk
