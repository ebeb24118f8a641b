// The descriptor bindings and push-constant size of every embedded shader, read from its SPIR-V
// at build time (`spirv-cross --reflect`, cmake/shader_layouts.cmake). The device layer builds
// descriptor-set and pipeline layouts and sizes descriptor pools from it, and checks each
// dispatch's buffers and push constants against it: a shader and its C++ caller cannot drift.
#pragma once

#include <vulkan/vulkan_core.h>

#include <cstdint>
#include <span>
#include <string_view>

namespace blobvk::vk {

struct ShaderBinding {
  VkDescriptorType type;  // storage or uniform buffer
  const char* block;      // the GLSL block name, for messages
};

struct ShaderLayout {
  const char* shader;                     // registry name ("field_grid", "render_mesh.vert")
  std::span<const ShaderBinding> bindings;  // set 0, binding i at [i]
  std::uint32_t pushConstantBytes = 0;    // 0: no push-constant block
};

// The layout of an embedded shader, or null for an unknown name.
const ShaderLayout* findShaderLayout(std::string_view shader);
// Every embedded shader's layout.
std::span<const ShaderLayout> shaderLayouts();

}  // namespace blobvk::vk
