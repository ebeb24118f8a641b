// embed_host: a minimal Vulkan "engine" that embeds blobvk the way a real one would.
//
// The host creates its own instance, device, queue, command buffer, render pass and pipeline.
// blobvk gets the handles (HostContext), records the GPU polygonizer into the host's command
// buffer, and leaves a VkDrawIndexedIndirectCommand on the GPU; the host draws the mesh with its
// own pipeline straight from those counts (no read-back) and writes a PNG.
//
//   embed_host [--validation] [--output out.png] [--size N]
// Exit codes: 0 ok, 1 failure (including any validation message), 77 no Vulkan device (skip).
#include "blobvk/vulkan.h"

#include "host_mesh_frag.h"
#include "host_mesh_vert.h"

#include <glm/gtc/matrix_transform.hpp>
#include <glm/mat4x4.hpp>
#include <png.h>
#include <vulkan/vulkan.h>

#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

std::uint32_t g_validationMessages = 0;

VKAPI_ATTR VkBool32 VKAPI_CALL onValidation(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                            VkDebugUtilsMessageTypeFlagsEXT,
                                            const VkDebugUtilsMessengerCallbackDataEXT* data, void*) {
  if (severity >= VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT) {
    ++g_validationMessages;
    std::fprintf(stderr, "validation: %s\n", data->pMessage);
  }
  return VK_FALSE;
}

void ok(VkResult r, const char* what) {
  if (r != VK_SUCCESS) throw std::runtime_error(std::string(what) + " failed (" + std::to_string(r) + ")");
}

std::uint32_t memoryType(VkPhysicalDevice pd, std::uint32_t bits, VkMemoryPropertyFlags want) {
  VkPhysicalDeviceMemoryProperties props;
  vkGetPhysicalDeviceMemoryProperties(pd, &props);
  for (std::uint32_t i = 0; i < props.memoryTypeCount; ++i) {
    if ((bits & (1u << i)) && (props.memoryTypes[i].propertyFlags & want) == want) return i;
  }
  throw std::runtime_error("no suitable memory type");
}

struct HostImage {
  VkImage image = VK_NULL_HANDLE;
  VkDeviceMemory memory = VK_NULL_HANDLE;
  VkImageView view = VK_NULL_HANDLE;
};

HostImage makeImage(VkPhysicalDevice pd, VkDevice dev, VkFormat format, std::uint32_t size,
                    VkImageUsageFlags usage, VkImageAspectFlags aspect) {
  HostImage h;
  VkImageCreateInfo info{VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO};
  info.imageType = VK_IMAGE_TYPE_2D;
  info.format = format;
  info.extent = {size, size, 1};
  info.mipLevels = info.arrayLayers = 1;
  info.samples = VK_SAMPLE_COUNT_1_BIT;
  info.tiling = VK_IMAGE_TILING_OPTIMAL;
  info.usage = usage;
  ok(vkCreateImage(dev, &info, nullptr, &h.image), "vkCreateImage");
  VkMemoryRequirements req;
  vkGetImageMemoryRequirements(dev, h.image, &req);
  VkMemoryAllocateInfo alloc{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
  alloc.allocationSize = req.size;
  alloc.memoryTypeIndex = memoryType(pd, req.memoryTypeBits, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
  ok(vkAllocateMemory(dev, &alloc, nullptr, &h.memory), "vkAllocateMemory");
  ok(vkBindImageMemory(dev, h.image, h.memory, 0), "vkBindImageMemory");
  VkImageViewCreateInfo view{VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO};
  view.image = h.image;
  view.viewType = VK_IMAGE_VIEW_TYPE_2D;
  view.format = format;
  view.subresourceRange = {aspect, 0, 1, 0, 1};
  ok(vkCreateImageView(dev, &view, nullptr, &h.view), "vkCreateImageView");
  return h;
}

void destroy(VkDevice dev, HostImage& h) {
  vkDestroyImageView(dev, h.view, nullptr);
  vkDestroyImage(dev, h.image, nullptr);
  vkFreeMemory(dev, h.memory, nullptr);
}

VkShaderModule shader(VkDevice dev, const std::uint32_t* code, std::size_t bytes) {
  VkShaderModuleCreateInfo info{VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
  info.codeSize = bytes;
  info.pCode = code;
  VkShaderModule m;
  ok(vkCreateShaderModule(dev, &info, nullptr, &m), "vkCreateShaderModule");
  return m;
}

// The model: three blended points, made and compiled with blobvk's core API.
blobvk::blobtree::Node model() {
  using namespace blobvk::blobtree;
  Operator blend;
  blend.type = OperatorType::Blend;
  Node root{blend, "root", {}, {}};
  const glm::dvec3 centres[3] = {{-0.6, 0, 0}, {0.6, 0, 0}, {0, 0.7, 0.2}};
  for (const auto& c : centres) {
    Primitive p;
    p.type = PrimitiveType::Point;
    p.a = c;
    p.support = 1.3;
    root.children.push_back(Node{p, "", {}, {}});
  }
  return root;
}

int run(bool validation, const std::string& output, std::uint32_t size) {
  // ---- the host's own instance and device -------------------------------------------------
  VkApplicationInfo app{VK_STRUCTURE_TYPE_APPLICATION_INFO};
  app.pApplicationName = "blobvk embed_host";
  app.apiVersion = VK_API_VERSION_1_1;
  const char* layer = "VK_LAYER_KHRONOS_validation";
  const char* extensions[] = {VK_EXT_DEBUG_UTILS_EXTENSION_NAME, VK_EXT_VALIDATION_FEATURES_EXTENSION_NAME};
  // Synchronisation validation as well as the core checks, as an engine's debug build runs.
  const VkValidationFeatureEnableEXT enables[] = {VK_VALIDATION_FEATURE_ENABLE_SYNCHRONIZATION_VALIDATION_EXT};
  VkValidationFeaturesEXT features{VK_STRUCTURE_TYPE_VALIDATION_FEATURES_EXT};
  features.enabledValidationFeatureCount = 1;
  features.pEnabledValidationFeatures = enables;
  VkInstanceCreateInfo ii{VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
  ii.pApplicationInfo = &app;
  if (validation) {
    ii.pNext = &features;
    ii.enabledLayerCount = 1;
    ii.ppEnabledLayerNames = &layer;
    ii.enabledExtensionCount = 2;
    ii.ppEnabledExtensionNames = extensions;
  }
  VkInstance instance;
  if (vkCreateInstance(&ii, nullptr, &instance) != VK_SUCCESS) {
    std::fprintf(stderr, "embed_host: no Vulkan instance%s; skipping\n", validation ? " with validation" : "");
    return 77;
  }
  VkDebugUtilsMessengerEXT messenger = VK_NULL_HANDLE;
  if (validation) {
    VkDebugUtilsMessengerCreateInfoEXT mi{VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT};
    mi.messageSeverity = VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT;
    mi.messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
                     VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT;
    mi.pfnUserCallback = onValidation;
    auto create = reinterpret_cast<PFN_vkCreateDebugUtilsMessengerEXT>(
        vkGetInstanceProcAddr(instance, "vkCreateDebugUtilsMessengerEXT"));
    ok(create(instance, &mi, nullptr, &messenger), "vkCreateDebugUtilsMessengerEXT");
  }
  std::uint32_t count = 0;
  vkEnumeratePhysicalDevices(instance, &count, nullptr);
  std::vector<VkPhysicalDevice> devices(count);
  vkEnumeratePhysicalDevices(instance, &count, devices.data());
  VkPhysicalDevice pd = VK_NULL_HANDLE;
  std::uint32_t family = 0;
  for (auto d : devices) {
    std::uint32_t n = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(d, &n, nullptr);
    std::vector<VkQueueFamilyProperties> families(n);
    vkGetPhysicalDeviceQueueFamilyProperties(d, &n, families.data());
    for (std::uint32_t i = 0; i < n && !pd; ++i) {
      const VkQueueFlags need = VK_QUEUE_GRAPHICS_BIT | VK_QUEUE_COMPUTE_BIT;
      if ((families[i].queueFlags & need) == need) {
        pd = d;
        family = i;
      }
    }
    if (pd) break;
  }
  if (!pd) {
    std::fprintf(stderr, "embed_host: no device with a graphics+compute queue; skipping\n");
    vkDestroyInstance(instance, nullptr);
    return 77;
  }
  const float priority = 1.0f;
  VkDeviceQueueCreateInfo qi{VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO};
  qi.queueFamilyIndex = family;
  qi.queueCount = 1;
  qi.pQueuePriorities = &priority;
  VkDeviceCreateInfo di{VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO};
  di.queueCreateInfoCount = 1;
  di.pQueueCreateInfos = &qi;
  VkDevice dev;
  ok(vkCreateDevice(pd, &di, nullptr, &dev), "vkCreateDevice");
  VkQueue queue;
  vkGetDeviceQueue(dev, family, 0, &queue);

  bool covered = false;
  {
    // ---- blobvk on the host's device ---------------------------------------------------------
    blobvk::vk::HostContext host;
    host.instance = instance;
    host.physicalDevice = pd;
    host.device = dev;
    host.queueFamilyIndex = family;
    host.queue = queue;  // blobvk's one-shot helpers only; none runs here (uploads are recorded)
    host.getInstanceProcAddr = vkGetInstanceProcAddr;
    host.instanceApiVersion = VK_API_VERSION_1_1;  // as the instance was created (app.apiVersion)
    blobvk::vk::Device bdev(host);
    const auto program = blobvk::blobtree::compile(model());
    blobvk::blobtree::GridRequest request;
    request.resolution = 48;
    const auto grid = blobvk::blobtree::chooseGrid(program, {}, request);
    // Uploads the polygonizer makes (Program records, tables) into memory the host cannot map
    // become copies recorded into our command buffer below, not blocking submits; the batch owns
    // the staging buffers, so it lives until the fence.
    blobvk::vk::UploadBatch uploads(bdev);
    blobvk::vk::SlabPolygonizer poly(bdev, program, grid, {});
    if (poly.slabCount() != 1) throw std::runtime_error("expected a single-slab grid");
    const auto plan = poly.plan(0);
    // Worst-case capacity: 3 vertices per grid point, 5 triangles per cell.
    const VkBufferUsageFlags draw = VK_BUFFER_USAGE_VERTEX_BUFFER_BIT | VK_BUFFER_USAGE_INDEX_BUFFER_BIT;
    auto positions = bdev.createBuffer(plan.ownedPoints * 36, blobvk::vk::MemoryUse::DeviceLocal, draw);
    auto normals = bdev.createBuffer(plan.ownedPoints * 36, blobvk::vk::MemoryUse::DeviceLocal, draw);
    auto colours = bdev.createBuffer(plan.ownedPoints * 36);
    auto keys = bdev.createBuffer(plan.ownedPoints * 12);
    auto indices = bdev.createBuffer(plan.cells * 60, blobvk::vk::MemoryUse::DeviceLocal, draw);

    // ---- the host's render pass, framebuffer and pipeline -------------------------------------
    HostImage colour = makeImage(pd, dev, VK_FORMAT_R8G8B8A8_UNORM, size,
                                 VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT,
                                 VK_IMAGE_ASPECT_COLOR_BIT);
    HostImage depth = makeImage(pd, dev, VK_FORMAT_D32_SFLOAT, size, VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT,
                                VK_IMAGE_ASPECT_DEPTH_BIT);
    VkAttachmentDescription att[2]{};
    att[0] = {0, VK_FORMAT_R8G8B8A8_UNORM, VK_SAMPLE_COUNT_1_BIT, VK_ATTACHMENT_LOAD_OP_CLEAR,
              VK_ATTACHMENT_STORE_OP_STORE, VK_ATTACHMENT_LOAD_OP_DONT_CARE, VK_ATTACHMENT_STORE_OP_DONT_CARE,
              VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL};
    att[1] = {0, VK_FORMAT_D32_SFLOAT, VK_SAMPLE_COUNT_1_BIT, VK_ATTACHMENT_LOAD_OP_CLEAR,
              VK_ATTACHMENT_STORE_OP_DONT_CARE, VK_ATTACHMENT_LOAD_OP_DONT_CARE, VK_ATTACHMENT_STORE_OP_DONT_CARE,
              VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL};
    VkAttachmentReference cref{0, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL};
    VkAttachmentReference dref{1, VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL};
    VkSubpassDescription sub{};
    sub.pipelineBindPoint = VK_PIPELINE_BIND_POINT_GRAPHICS;
    sub.colorAttachmentCount = 1;
    sub.pColorAttachments = &cref;
    sub.pDepthStencilAttachment = &dref;
    VkSubpassDependency dep{0, VK_SUBPASS_EXTERNAL, VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT,
                            VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT,
                            VK_ACCESS_TRANSFER_READ_BIT, 0};
    VkRenderPassCreateInfo rpi{VK_STRUCTURE_TYPE_RENDER_PASS_CREATE_INFO};
    rpi.attachmentCount = 2;
    rpi.pAttachments = att;
    rpi.subpassCount = 1;
    rpi.pSubpasses = &sub;
    rpi.dependencyCount = 1;
    rpi.pDependencies = &dep;
    VkRenderPass renderPass;
    ok(vkCreateRenderPass(dev, &rpi, nullptr, &renderPass), "vkCreateRenderPass");
    VkImageView views[2] = {colour.view, depth.view};
    VkFramebufferCreateInfo fbi{VK_STRUCTURE_TYPE_FRAMEBUFFER_CREATE_INFO};
    fbi.renderPass = renderPass;
    fbi.attachmentCount = 2;
    fbi.pAttachments = views;
    fbi.width = fbi.height = size;
    fbi.layers = 1;
    VkFramebuffer framebuffer;
    ok(vkCreateFramebuffer(dev, &fbi, nullptr, &framebuffer), "vkCreateFramebuffer");

    VkPushConstantRange range{VK_SHADER_STAGE_VERTEX_BIT, 0, sizeof(glm::mat4)};
    VkPipelineLayoutCreateInfo pli{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
    pli.pushConstantRangeCount = 1;
    pli.pPushConstantRanges = &range;
    VkPipelineLayout layout;
    ok(vkCreatePipelineLayout(dev, &pli, nullptr, &layout), "vkCreatePipelineLayout");
    VkShaderModule vs = shader(dev, host_mesh_vert, sizeof(host_mesh_vert));
    VkShaderModule fs = shader(dev, host_mesh_frag, sizeof(host_mesh_frag));
    VkPipelineShaderStageCreateInfo stages[2] = {
        {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO, nullptr, 0, VK_SHADER_STAGE_VERTEX_BIT, vs, "main", nullptr},
        {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO, nullptr, 0, VK_SHADER_STAGE_FRAGMENT_BIT, fs, "main", nullptr}};
    VkVertexInputBindingDescription vb[2] = {{0, 12, VK_VERTEX_INPUT_RATE_VERTEX}, {1, 12, VK_VERTEX_INPUT_RATE_VERTEX}};
    VkVertexInputAttributeDescription va[2] = {{0, 0, VK_FORMAT_R32G32B32_SFLOAT, 0}, {1, 1, VK_FORMAT_R32G32B32_SFLOAT, 0}};
    VkPipelineVertexInputStateCreateInfo vi{VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO};
    vi.vertexBindingDescriptionCount = 2;
    vi.pVertexBindingDescriptions = vb;
    vi.vertexAttributeDescriptionCount = 2;
    vi.pVertexAttributeDescriptions = va;
    VkPipelineInputAssemblyStateCreateInfo ia{VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO};
    ia.topology = VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST;
    VkViewport viewport{0, 0, float(size), float(size), 0, 1};
    VkRect2D scissor{{0, 0}, {size, size}};
    VkPipelineViewportStateCreateInfo vp{VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO};
    vp.viewportCount = vp.scissorCount = 1;
    vp.pViewports = &viewport;
    vp.pScissors = &scissor;
    VkPipelineRasterizationStateCreateInfo rs{VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO};
    rs.cullMode = VK_CULL_MODE_NONE;
    rs.lineWidth = 1.0f;
    VkPipelineMultisampleStateCreateInfo ms{VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO};
    ms.rasterizationSamples = VK_SAMPLE_COUNT_1_BIT;
    VkPipelineDepthStencilStateCreateInfo ds{VK_STRUCTURE_TYPE_PIPELINE_DEPTH_STENCIL_STATE_CREATE_INFO};
    ds.depthTestEnable = ds.depthWriteEnable = VK_TRUE;
    ds.depthCompareOp = VK_COMPARE_OP_LESS;
    VkPipelineColorBlendAttachmentState cba{};
    cba.colorWriteMask = 0xf;
    VkPipelineColorBlendStateCreateInfo cb{VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO};
    cb.attachmentCount = 1;
    cb.pAttachments = &cba;
    VkGraphicsPipelineCreateInfo gpi{VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO};
    gpi.stageCount = 2;
    gpi.pStages = stages;
    gpi.pVertexInputState = &vi;
    gpi.pInputAssemblyState = &ia;
    gpi.pViewportState = &vp;
    gpi.pRasterizationState = &rs;
    gpi.pMultisampleState = &ms;
    gpi.pDepthStencilState = &ds;
    gpi.pColorBlendState = &cb;
    gpi.layout = layout;
    gpi.renderPass = renderPass;
    VkPipeline pipeline;
    ok(vkCreateGraphicsPipelines(dev, VK_NULL_HANDLE, 1, &gpi, nullptr, &pipeline), "vkCreateGraphicsPipelines");
    vkDestroyShaderModule(dev, vs, nullptr);
    vkDestroyShaderModule(dev, fs, nullptr);

    VkBufferCreateInfo bi{VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
    bi.size = VkDeviceSize(size) * size * 4;
    bi.usage = VK_BUFFER_USAGE_TRANSFER_DST_BIT;
    VkBuffer readback;
    ok(vkCreateBuffer(dev, &bi, nullptr, &readback), "vkCreateBuffer");
    VkMemoryRequirements req;
    vkGetBufferMemoryRequirements(dev, readback, &req);
    VkMemoryAllocateInfo mai{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
    mai.allocationSize = req.size;
    mai.memoryTypeIndex = memoryType(pd, req.memoryTypeBits,
                                     VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT);
    VkDeviceMemory readbackMemory;
    ok(vkAllocateMemory(dev, &mai, nullptr, &readbackMemory), "vkAllocateMemory");
    ok(vkBindBufferMemory(dev, readback, readbackMemory, 0), "vkBindBufferMemory");

    // ---- one command buffer: blobvk records, the host draws -----------------------------------
    VkCommandPoolCreateInfo cpi{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
    cpi.queueFamilyIndex = family;
    VkCommandPool pool;
    ok(vkCreateCommandPool(dev, &cpi, nullptr, &pool), "vkCreateCommandPool");
    VkCommandBufferAllocateInfo cai{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
    cai.commandPool = pool;
    cai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    cai.commandBufferCount = 1;
    VkCommandBuffer cmd;
    ok(vkAllocateCommandBuffers(dev, &cai, &cmd), "vkAllocateCommandBuffers");
    VkCommandBufferBeginInfo begin{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
    ok(vkBeginCommandBuffer(cmd, &begin), "vkBeginCommandBuffer");
    uploads.record(cmd);  // the copies, then a transfer -> compute barrier (docs/embedding.md)
    {
      // The Recorder owns the descriptor sets of blobvk's dispatches: keep it until the fence.
      blobvk::vk::Recorder rec(bdev, cmd);
      poly.recordClassify(rec, 0, 0, 0);
      // The capacities we allocated: blobvk never writes past them and flags a mesh that
      // does not fit (drawArgs() word kOverflowWord, SlabPolygonizer::readOverflow()).
      poly.recordEmit(rec, 0, 0, {positions, normals, colours, keys, indices, std::uint32_t(3 * plan.ownedPoints),
                                  std::uint32_t(5 * plan.cells)});
      // blobvk leaves its writes visible to compute, transfer and indirect reads; the host adds
      // what its draw needs: vertex and index input.
      VkMemoryBarrier mb{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
      mb.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT;
      mb.dstAccessMask = VK_ACCESS_VERTEX_ATTRIBUTE_READ_BIT | VK_ACCESS_INDEX_READ_BIT |
                         VK_ACCESS_INDIRECT_COMMAND_READ_BIT;
      vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
                           VK_PIPELINE_STAGE_VERTEX_INPUT_BIT | VK_PIPELINE_STAGE_DRAW_INDIRECT_BIT, 0, 1, &mb,
                           0, nullptr, 0, nullptr);
      VkClearValue clear[2]{};
      clear[0].color = {{0.05f, 0.05f, 0.08f, 1.0f}};
      clear[1].depthStencil = {1.0f, 0};
      VkRenderPassBeginInfo rbi{VK_STRUCTURE_TYPE_RENDER_PASS_BEGIN_INFO};
      rbi.renderPass = renderPass;
      rbi.framebuffer = framebuffer;
      rbi.renderArea = {{0, 0}, {size, size}};
      rbi.clearValueCount = 2;
      rbi.pClearValues = clear;
      vkCmdBeginRenderPass(cmd, &rbi, VK_SUBPASS_CONTENTS_INLINE);
      glm::mat4 proj = glm::perspectiveRH_ZO(glm::radians(45.0f), 1.0f, 0.1f, 20.0f);
      proj[1][1] *= -1.0f;
      const glm::mat4 viewProj = proj * glm::lookAtRH(glm::vec3(1.5f, 1.5f, 4.0f), glm::vec3(0, 0.2f, 0),
                                                      glm::vec3(0, 1, 0));
      vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline);
      vkCmdPushConstants(cmd, layout, VK_SHADER_STAGE_VERTEX_BIT, 0, sizeof(viewProj), &viewProj);
      const VkBuffer vbs[2] = {positions.handle(), normals.handle()};
      const VkDeviceSize offs[2] = {0, 0};
      vkCmdBindVertexBuffers(cmd, 0, 2, vbs, offs);
      vkCmdBindIndexBuffer(cmd, indices.handle(), 0, VK_INDEX_TYPE_UINT32);
      // The counts never leave the GPU: blobvk wrote the VkDrawIndexedIndirectCommand.
      vkCmdDrawIndexedIndirect(cmd, poly.drawArgs().handle(), 0, 1, 0);
      vkCmdEndRenderPass(cmd);
      VkBufferImageCopy region{};
      region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
      region.imageExtent = {size, size, 1};
      vkCmdCopyImageToBuffer(cmd, colour.image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, readback, 1, &region);
      // The host reads the image copy and the polygonizer's overflow word (poly.readOverflow(),
      // written by its compute pass): both writes made visible to the host.
      VkMemoryBarrier hb{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
      hb.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT | VK_ACCESS_SHADER_WRITE_BIT;
      hb.dstAccessMask = VK_ACCESS_HOST_READ_BIT;
      vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT | VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
                           VK_PIPELINE_STAGE_HOST_BIT, 0, 1, &hb, 0, nullptr, 0, nullptr);
      ok(vkEndCommandBuffer(cmd), "vkEndCommandBuffer");
      VkFenceCreateInfo fi{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
      VkFence fence;
      ok(vkCreateFence(dev, &fi, nullptr, &fence), "vkCreateFence");
      VkSubmitInfo si{VK_STRUCTURE_TYPE_SUBMIT_INFO};
      si.commandBufferCount = 1;
      si.pCommandBuffers = &cmd;
      ok(vkQueueSubmit(queue, 1, &si, fence), "vkQueueSubmit");
      ok(vkWaitForFences(dev, 1, &fence, VK_TRUE, UINT64_MAX), "vkWaitForFences");
      vkDestroyFence(dev, fence, nullptr);
    }

    // ---- PNG and a sanity check ---------------------------------------------------------------
    if (poly.readOverflow()) throw std::runtime_error("the mesh overflowed its buffers");
    void* mapped = nullptr;
    ok(vkMapMemory(dev, readbackMemory, 0, VK_WHOLE_SIZE, 0, &mapped), "vkMapMemory");
    std::vector<std::uint8_t> rgba(std::size_t(size) * size * 4);
    std::memcpy(rgba.data(), mapped, rgba.size());
    vkUnmapMemory(dev, readbackMemory);
    std::size_t lit = 0;
    for (std::size_t i = 0; i < rgba.size(); i += 4) lit += rgba[i + 2] > 60;
    covered = lit > std::size_t(size) * size / 20;
    std::printf("embed_host: %zu of %u pixels show the mesh\n", lit, size * size);
    png_image image{};
    image.version = PNG_IMAGE_VERSION;
    image.width = size;
    image.height = size;
    image.format = PNG_FORMAT_RGBA;
    if (!png_image_write_to_file(&image, output.c_str(), 0, rgba.data(), 0, nullptr)) {
      throw std::runtime_error("cannot write " + output);
    }

    vkDestroyCommandPool(dev, pool, nullptr);
    vkDestroyBuffer(dev, readback, nullptr);
    vkFreeMemory(dev, readbackMemory, nullptr);
    vkDestroyPipeline(dev, pipeline, nullptr);
    vkDestroyPipelineLayout(dev, layout, nullptr);
    vkDestroyFramebuffer(dev, framebuffer, nullptr);
    vkDestroyRenderPass(dev, renderPass, nullptr);
    destroy(dev, colour);
    destroy(dev, depth);
  }  // blobvk's Device and buffers go before the host's device
  vkDestroyDevice(dev, nullptr);
  if (messenger) {
    auto destroyMessenger = reinterpret_cast<PFN_vkDestroyDebugUtilsMessengerEXT>(
        vkGetInstanceProcAddr(instance, "vkDestroyDebugUtilsMessengerEXT"));
    destroyMessenger(instance, messenger, nullptr);
  }
  vkDestroyInstance(instance, nullptr);
  if (g_validationMessages) {
    std::fprintf(stderr, "embed_host: %u validation message(s)\n", g_validationMessages);
    return 1;
  }
  if (!covered) {
    std::fprintf(stderr, "embed_host: the mesh did not show up in the image\n");
    return 1;
  }
  std::printf("embed_host: wrote %s\n", output.c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  bool validation = false;
  std::string output = "embed_host.png";
  std::uint32_t size = 256;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--validation") validation = true;
    else if (arg == "--output" && i + 1 < argc) output = argv[++i];
    else if (arg == "--size" && i + 1 < argc) size = std::uint32_t(std::stoul(argv[++i]));
    else {
      std::fprintf(stderr, "usage: embed_host [--validation] [--output out.png] [--size N]\n");
      return 2;
    }
  }
  try {
    return run(validation, output, size);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "embed_host: error: %s\n", e.what());
    return 1;
  }
}
