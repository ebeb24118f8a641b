#include "blobvk/vk/render/render_mesh.h"

#include "blobvk/vk/device/error.h"
#include "blobvk/vk/render/render_target.h"
#include "blobvk/vk/device/shader_layout.h"
#include "blobvk/vk/device/shader_registry.h"

#include <glm/geometric.hpp>
#include <glm/mat4x4.hpp>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <string>
#include <vector>

namespace blobvk::vk {
namespace {

struct Push {
  glm::mat4 viewProj;
  float eyeDepthBias[4];
  float lightMode[4];
  float lineColour[4];
};
static_assert(sizeof(Push) == 112);

std::vector<mesh::Float3> vertexNormals(const mesh::TriMesh& m) {
  std::vector<glm::vec3> n(m.positions.size(), glm::vec3(0.0f));
  auto v = [&](std::uint32_t i) { return glm::vec3(m.positions[i].x, m.positions[i].y, m.positions[i].z); };
  for (const auto& t : m.triangles) {
    const glm::vec3 f = glm::cross(v(t[1]) - v(t[0]), v(t[2]) - v(t[0]));  // area-weighted
    for (auto i : t) n[i] += f;
  }
  std::vector<mesh::Float3> out(n.size());
  for (std::size_t i = 0; i < n.size(); ++i) {
    const float len = glm::length(n[i]);
    const glm::vec3 u = len > 0.0f ? n[i] / len : glm::vec3(0, 0, 1);
    out[i] = {u.x, u.y, u.z};
  }
  return out;
}

std::vector<std::uint32_t> uniqueEdges(const mesh::TriMesh& m) {
  std::vector<std::uint64_t> keys;
  keys.reserve(m.triangles.size() * 3);
  for (const auto& t : m.triangles) {
    for (int e = 0; e < 3; ++e) {
      std::uint32_t a = t[e], b = t[(e + 1) % 3];
      if (a > b) std::swap(a, b);
      keys.push_back(std::uint64_t(a) << 32 | b);
    }
  }
  std::sort(keys.begin(), keys.end());
  keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
  std::vector<std::uint32_t> lines;
  lines.reserve(keys.size() * 2);
  for (auto k : keys) {
    lines.push_back(std::uint32_t(k >> 32));
    lines.push_back(std::uint32_t(k));
  }
  return lines;
}

constexpr VkBufferUsageFlags kDrawUsage = VK_BUFFER_USAGE_VERTEX_BUFFER_BIT | VK_BUFFER_USAGE_INDEX_BUFFER_BIT;

Buffer uploadArray(Device& device, const void* data, std::size_t bytes) {
  Buffer b = device.createBuffer(std::max<std::size_t>(bytes, 16), MemoryUse::DeviceLocal, kDrawUsage);
  device.upload(b, data, bytes);
  return b;
}

VkShaderModule module(Device& device, const char* name) {
  const auto code = shaderCode(name);
  VkShaderModuleCreateInfo info{VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
  info.codeSize = code.size() * 4;
  info.pCode = code.data();
  VkShaderModule m = VK_NULL_HANDLE;
  check(device.d().vkCreateShaderModule(device.handle(), &info, nullptr, &m), "vkCreateShaderModule");
  return m;
}

}  // namespace

MeshView UploadedMesh::view() const {
  MeshView v;
  v.positions = positions.handle();
  v.normals = normals.handle();
  v.colours = colours.handle();
  v.indices = indices.handle();
  v.indexCount = indexCount;
  v.lineIndices = lines.handle();
  v.lineIndexCount = lineIndexCount;
  return v;
}

UploadedMesh uploadMesh(Device& device, const mesh::TriMesh& m, const RenderStyle& style) {
  UploadedMesh u;
  const std::size_t n = m.positions.size();
  u.positions = uploadArray(device, m.positions.data(), n * 12);
  const std::vector<mesh::Float3> computed = m.normals.size() == n ? std::vector<mesh::Float3>{} : vertexNormals(m);
  u.normals = uploadArray(device, m.normals.size() == n ? m.normals.data() : computed.data(), n * 12);
  std::vector<mesh::Float3> fill;
  if (m.colours.size() != n) {
    fill.assign(n, {style.defaultColour[0], style.defaultColour[1], style.defaultColour[2]});
  }
  u.colours = uploadArray(device, fill.empty() ? m.colours.data() : fill.data(), n * 12);
  u.indices = uploadArray(device, m.triangles.data(), m.triangles.size() * 12);
  u.indexCount = std::uint32_t(m.triangles.size() * 3);
  if (style.wireframe) {
    const auto lines = uniqueEdges(m);
    u.lines = uploadArray(device, lines.data(), lines.size() * 4);
    u.lineIndexCount = std::uint32_t(lines.size());
  }
  return u;
}

MeshPipeline::MeshPipeline(Device& device, const RenderDispatch& rd, VkRenderPass renderPass,
                           VkSampleCountFlagBits samples)
    : device_(device), rd_(rd) {
  const auto& d = device.d();
  // The stages' push-constant blocks, as their SPIR-V declares them (vk/device/shader_layout.h), must be
  // what Push holds: a shader edited without this struct fails here, not on the screen.
  for (const char* stage : {"render_mesh.vert", "render_mesh.frag"}) {
    const ShaderLayout* reflected = findShaderLayout(stage);
    if (!reflected || !reflected->bindings.empty() || reflected->pushConstantBytes != sizeof(Push)) {
      throw VulkanError(std::string(stage) + ": its push-constant block is not vk/render/render_mesh.cpp's Push (" +
                        std::to_string(sizeof(Push)) + " bytes, no descriptors)");
    }
  }
  VkPushConstantRange range{VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, 0, sizeof(Push)};
  VkPipelineLayoutCreateInfo layoutInfo{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  layoutInfo.pushConstantRangeCount = 1;
  layoutInfo.pPushConstantRanges = &range;
  check(d.vkCreatePipelineLayout(device.handle(), &layoutInfo, nullptr, &layout_), "vkCreatePipelineLayout");

  VkShaderModule vert = module(device, "render_mesh.vert");
  VkShaderModule frag = VK_NULL_HANDLE;
  try {
    frag = module(device, "render_mesh.frag");
    VkPipelineShaderStageCreateInfo stages[2]{};
    stages[0] = {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO, nullptr, 0, VK_SHADER_STAGE_VERTEX_BIT,
                 vert, "main", nullptr};
    stages[1] = {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO, nullptr, 0, VK_SHADER_STAGE_FRAGMENT_BIT,
                 frag, "main", nullptr};
    VkVertexInputBindingDescription bindings[3];
    VkVertexInputAttributeDescription attributes[3];
    for (std::uint32_t i = 0; i < 3; ++i) {
      bindings[i] = {i, 12, VK_VERTEX_INPUT_RATE_VERTEX};
      attributes[i] = {i, i, VK_FORMAT_R32G32B32_SFLOAT, 0};
    }
    VkPipelineVertexInputStateCreateInfo vertexInput{VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO};
    vertexInput.vertexBindingDescriptionCount = 3;
    vertexInput.pVertexBindingDescriptions = bindings;
    vertexInput.vertexAttributeDescriptionCount = 3;
    vertexInput.pVertexAttributeDescriptions = attributes;
    VkPipelineInputAssemblyStateCreateInfo assembly{VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO};
    assembly.topology = VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST;
    VkPipelineViewportStateCreateInfo viewport{VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO};
    viewport.viewportCount = 1;
    viewport.scissorCount = 1;
    VkPipelineRasterizationStateCreateInfo raster{VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO};
    raster.polygonMode = VK_POLYGON_MODE_FILL;
    raster.cullMode = VK_CULL_MODE_NONE;  // closed meshes need no culling; open ones show both sides
    raster.frontFace = VK_FRONT_FACE_COUNTER_CLOCKWISE;
    raster.lineWidth = 1.0f;
    VkPipelineMultisampleStateCreateInfo multisample{VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO};
    multisample.rasterizationSamples = samples;
    VkPipelineDepthStencilStateCreateInfo depth{VK_STRUCTURE_TYPE_PIPELINE_DEPTH_STENCIL_STATE_CREATE_INFO};
    depth.depthTestEnable = VK_TRUE;
    depth.depthWriteEnable = VK_TRUE;
    depth.depthCompareOp = VK_COMPARE_OP_LESS_OR_EQUAL;
    VkPipelineColorBlendAttachmentState blendAttachment{};
    blendAttachment.colorWriteMask = VK_COLOR_COMPONENT_R_BIT | VK_COLOR_COMPONENT_G_BIT |
                                     VK_COLOR_COMPONENT_B_BIT | VK_COLOR_COMPONENT_A_BIT;
    VkPipelineColorBlendStateCreateInfo blend{VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO};
    blend.attachmentCount = 1;
    blend.pAttachments = &blendAttachment;
    const VkDynamicState dynamicStates[2] = {VK_DYNAMIC_STATE_VIEWPORT, VK_DYNAMIC_STATE_SCISSOR};
    VkPipelineDynamicStateCreateInfo dynamic{VK_STRUCTURE_TYPE_PIPELINE_DYNAMIC_STATE_CREATE_INFO};
    dynamic.dynamicStateCount = 2;
    dynamic.pDynamicStates = dynamicStates;
    VkGraphicsPipelineCreateInfo info{VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO};
    info.stageCount = 2;
    info.pStages = stages;
    info.pVertexInputState = &vertexInput;
    info.pInputAssemblyState = &assembly;
    info.pViewportState = &viewport;
    info.pRasterizationState = &raster;
    info.pMultisampleState = &multisample;
    info.pDepthStencilState = &depth;
    info.pColorBlendState = &blend;
    info.pDynamicState = &dynamic;
    info.layout = layout_;
    info.renderPass = renderPass;
    info.subpass = 0;
    check(rd_.vkCreateGraphicsPipelines(device.handle(), device.pipelineCache(), 1, &info, nullptr, &triangles_),
          "vkCreateGraphicsPipelines");
    // Wireframe: the same shaders over a line list of unique edges (no fillModeNonSolid needed).
    assembly.topology = VK_PRIMITIVE_TOPOLOGY_LINE_LIST;
    check(rd_.vkCreateGraphicsPipelines(device.handle(), device.pipelineCache(), 1, &info, nullptr, &lines_),
          "vkCreateGraphicsPipelines");
  } catch (...) {
    d.vkDestroyShaderModule(device.handle(), vert, nullptr);
    if (frag) d.vkDestroyShaderModule(device.handle(), frag, nullptr);
    release();
    throw;
  }
  d.vkDestroyShaderModule(device.handle(), vert, nullptr);
  d.vkDestroyShaderModule(device.handle(), frag, nullptr);
}

MeshPipeline::~MeshPipeline() { release(); }

void MeshPipeline::release() {
  const auto& d = device_.d();
  if (lines_) d.vkDestroyPipeline(device_.handle(), lines_, nullptr);
  if (triangles_) d.vkDestroyPipeline(device_.handle(), triangles_, nullptr);
  if (layout_) d.vkDestroyPipelineLayout(device_.handle(), layout_, nullptr);
  lines_ = triangles_ = VK_NULL_HANDLE;
  layout_ = VK_NULL_HANDLE;
}

void MeshPipeline::recordDraw(VkCommandBuffer cmd, const MeshView& mesh, const Camera& camera,
                              float aspect, const RenderStyle& style) const {
  if (!mesh.positions || !mesh.indices || (!mesh.indirect && mesh.indexCount == 0)) return;
  const auto& d = device_.d();
  Push push{};
  push.viewProj = viewProjection(camera, aspect);
  const glm::vec3 light = headlight(camera);
  push.eyeDepthBias[0] = camera.eye.x;
  push.eyeDepthBias[1] = camera.eye.y;
  push.eyeDepthBias[2] = camera.eye.z;
  push.lightMode[0] = light.x;
  push.lightMode[1] = light.y;
  push.lightMode[2] = light.z;
  for (int i = 0; i < 3; ++i) push.lineColour[i] = style.wireColour[i];

  const VkBuffer vertexBuffers[3] = {mesh.positions, mesh.normals, mesh.colours};
  const VkDeviceSize offsets[3] = {0, 0, 0};
  d.vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, triangles_);
  d.vkCmdPushConstants(cmd, layout_, VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, 0,
                       sizeof(push), &push);
  rd_.vkCmdBindVertexBuffers(cmd, 0, 3, vertexBuffers, offsets);
  rd_.vkCmdBindIndexBuffer(cmd, mesh.indices, 0, VK_INDEX_TYPE_UINT32);
  if (mesh.indirect) {
    rd_.vkCmdDrawIndexedIndirect(cmd, mesh.indirect, mesh.indirectOffset, 1, 0);
  } else {
    rd_.vkCmdDrawIndexed(cmd, mesh.indexCount, 1, 0, 0, 0);
  }
  if (style.wireframe && mesh.lineIndices && mesh.lineIndexCount) {
    push.eyeDepthBias[3] = 2e-4f;  // pull lines in front of their own triangles
    push.lightMode[3] = 1.0f;
    d.vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, lines_);
    d.vkCmdPushConstants(cmd, layout_, VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, 0,
                         sizeof(push), &push);
    rd_.vkCmdBindIndexBuffer(cmd, mesh.lineIndices, 0, VK_INDEX_TYPE_UINT32);
    rd_.vkCmdDrawIndexed(cmd, mesh.lineIndexCount, 1, 0, 0, 0);
  }
}

MeshRenderer::MeshRenderer(Device& device, std::uint32_t width, std::uint32_t height, const RenderStyle& style)
    : device_(device), style_(style) {
  const auto& host = device.host();
  std::uint32_t familyCount = 0;
  device.d().vkGetPhysicalDeviceQueueFamilyProperties(host.physicalDevice, &familyCount, nullptr);
  std::vector<VkQueueFamilyProperties> families(familyCount);
  device.d().vkGetPhysicalDeviceQueueFamilyProperties(host.physicalDevice, &familyCount, families.data());
  if (host.queueFamilyIndex >= familyCount ||
      !(families[host.queueFamilyIndex].queueFlags & VK_QUEUE_GRAPHICS_BIT)) {
    throw VulkanError("the device's queue family " + std::to_string(host.queueFamilyIndex) +
                      " has no graphics support; the mesh renderer needs a graphics queue "
                      "(use --mode raycast, which needs only compute)");
  }
  rd_ = std::make_unique<RenderDispatch>(loadRenderDispatch(host.getInstanceProcAddr, host.instance, host.device));
  target_ = std::make_unique<OffscreenTarget>(device, *rd_, width, height, style.samples);
  pipeline_ = std::make_unique<MeshPipeline>(device, *rd_, target_->renderPass(), target_->samples());
}

MeshRenderer::~MeshRenderer() = default;

std::uint32_t MeshRenderer::samples() const { return std::uint32_t(target_->samples()); }

Image MeshRenderer::render(const mesh::TriMesh& mesh, const Camera& camera) {
  const UploadedMesh uploaded = uploadMesh(device_, mesh, style_);
  return render(uploaded.view(), camera);
}

Image MeshRenderer::render(const MeshView& mesh, const Camera& camera) {
  const float aspect = float(target_->width()) / float(target_->height());
  const auto t0 = std::chrono::steady_clock::now();
  device_.submitAndWait([&](VkCommandBuffer cmd) {
    target_->begin(cmd, style_.background.data());
    pipeline_->recordDraw(cmd, mesh, camera, aspect, style_);
    target_->end(cmd);
    target_->recordReadback(cmd);
  });
  lastSeconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return target_->read();
}

}  // namespace blobvk::vk
