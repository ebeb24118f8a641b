#include "blobvk/vk/render/render_target.h"

#include "blobvk/vk/device/error.h"

#include <cstring>
#include <vector>

namespace blobvk::vk {

VkSampleCountFlagBits supportedSamples(const Device& device, std::uint32_t wanted) {
  const auto& limits = device.info().limits;
  const VkSampleCountFlags ok = limits.framebufferColorSampleCounts & limits.framebufferDepthSampleCounts;
  for (std::uint32_t s = 8; s > 1; s /= 2) {
    if (s <= wanted && (ok & s)) return VkSampleCountFlagBits(s);
  }
  return VK_SAMPLE_COUNT_1_BIT;
}

namespace {
VkFormat pickDepthFormat(const Device& device, const RenderDispatch& rd) {
  for (VkFormat f : {VK_FORMAT_D32_SFLOAT, VK_FORMAT_X8_D24_UNORM_PACK32, VK_FORMAT_D16_UNORM}) {
    VkFormatProperties props{};
    rd.vkGetPhysicalDeviceFormatProperties(device.host().physicalDevice, f, &props);
    if (props.optimalTilingFeatures & VK_FORMAT_FEATURE_DEPTH_STENCIL_ATTACHMENT_BIT) return f;
  }
  throw VulkanError("device '" + device.info().name + "' has no usable depth format");
}
}  // namespace

OffscreenTarget::OffscreenTarget(Device& device, const RenderDispatch& rd, std::uint32_t width,
                                 std::uint32_t height, std::uint32_t samples)
    : device_(device), rd_(rd), width_(width), height_(height) {
  if (width == 0 || height == 0 || width > 16384 || height > 16384) {
    throw VulkanError("render size " + std::to_string(width) + "x" + std::to_string(height) +
                      " is out of range (1..16384)");
  }
  samples_ = supportedSamples(device, samples);
  depthFormat_ = pickDepthFormat(device, rd);
  const VkFormat colourFormat = VK_FORMAT_R8G8B8A8_UNORM;
  const bool msaa = samples_ != VK_SAMPLE_COUNT_1_BIT;
  try {
    colour_ = createAttachment(colourFormat,
                               msaa ? VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSIENT_ATTACHMENT_BIT
                                    : VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT,
                               samples_, VK_IMAGE_ASPECT_COLOR_BIT);
    depth_ = createAttachment(depthFormat_, VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT, samples_,
                              VK_IMAGE_ASPECT_DEPTH_BIT);
    if (msaa) {
      resolve_ = createAttachment(colourFormat,
                                  VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT,
                                  VK_SAMPLE_COUNT_1_BIT, VK_IMAGE_ASPECT_COLOR_BIT);
    }

    std::vector<VkAttachmentDescription> att(msaa ? 3 : 2);
    att[0].format = colourFormat;
    att[0].samples = samples_;
    att[0].loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
    att[0].storeOp = msaa ? VK_ATTACHMENT_STORE_OP_DONT_CARE : VK_ATTACHMENT_STORE_OP_STORE;
    att[0].stencilLoadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE;
    att[0].stencilStoreOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
    att[0].initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    att[0].finalLayout = msaa ? VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL : VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
    att[1] = att[0];
    att[1].format = depthFormat_;
    att[1].storeOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
    att[1].finalLayout = VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL;
    if (msaa) {
      att[2] = att[0];
      att[2].samples = VK_SAMPLE_COUNT_1_BIT;
      att[2].loadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE;
      att[2].storeOp = VK_ATTACHMENT_STORE_OP_STORE;
      att[2].finalLayout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
    }
    VkAttachmentReference colourRef{0, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL};
    VkAttachmentReference depthRef{1, VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL};
    VkAttachmentReference resolveRef{2, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL};
    VkSubpassDescription subpass{};
    subpass.pipelineBindPoint = VK_PIPELINE_BIND_POINT_GRAPHICS;
    subpass.colorAttachmentCount = 1;
    subpass.pColorAttachments = &colourRef;
    subpass.pResolveAttachments = msaa ? &resolveRef : nullptr;
    subpass.pDepthStencilAttachment = &depthRef;
    VkSubpassDependency deps[2]{};
    // Earlier use of the same images (previous frame's attachment writes, the copy that read
    // the resolved image) before this pass's clears and writes.
    deps[0].srcSubpass = VK_SUBPASS_EXTERNAL;
    deps[0].dstSubpass = 0;
    deps[0].srcStageMask = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT |
                           VK_PIPELINE_STAGE_LATE_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT;
    deps[0].srcAccessMask = VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT |
                            VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT;
    deps[0].dstStageMask = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT |
                           VK_PIPELINE_STAGE_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_LATE_FRAGMENT_TESTS_BIT;
    deps[0].dstAccessMask = VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT | VK_ACCESS_COLOR_ATTACHMENT_READ_BIT |
                            VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT |
                            VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_READ_BIT;
    // This pass's colour (and resolve) writes before the transfer that reads them back.
    deps[1].srcSubpass = 0;
    deps[1].dstSubpass = VK_SUBPASS_EXTERNAL;
    deps[1].srcStageMask = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT;
    deps[1].srcAccessMask = VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT;
    deps[1].dstStageMask = VK_PIPELINE_STAGE_TRANSFER_BIT;
    deps[1].dstAccessMask = VK_ACCESS_TRANSFER_READ_BIT;
    VkRenderPassCreateInfo rp{VK_STRUCTURE_TYPE_RENDER_PASS_CREATE_INFO};
    rp.attachmentCount = std::uint32_t(att.size());
    rp.pAttachments = att.data();
    rp.subpassCount = 1;
    rp.pSubpasses = &subpass;
    rp.dependencyCount = 2;
    rp.pDependencies = deps;
    check(rd_.vkCreateRenderPass(device_.handle(), &rp, nullptr, &renderPass_), "vkCreateRenderPass");

    VkImageView views[3] = {colour_.view, depth_.view, resolve_.view};
    VkFramebufferCreateInfo fb{VK_STRUCTURE_TYPE_FRAMEBUFFER_CREATE_INFO};
    fb.renderPass = renderPass_;
    fb.attachmentCount = msaa ? 3 : 2;
    fb.pAttachments = views;
    fb.width = width;
    fb.height = height;
    fb.layers = 1;
    check(rd_.vkCreateFramebuffer(device_.handle(), &fb, nullptr, &framebuffer_), "vkCreateFramebuffer");
    readback_ = device_.createBuffer(VkDeviceSize(width) * height * 4, MemoryUse::Readback);
  } catch (...) {
    release();
    throw;
  }
}

OffscreenTarget::~OffscreenTarget() { release(); }

void OffscreenTarget::release() {
  if (framebuffer_) rd_.vkDestroyFramebuffer(device_.handle(), framebuffer_, nullptr);
  if (renderPass_) rd_.vkDestroyRenderPass(device_.handle(), renderPass_, nullptr);
  framebuffer_ = VK_NULL_HANDLE;
  renderPass_ = VK_NULL_HANDLE;
  destroy(colour_);
  destroy(depth_);
  destroy(resolve_);
}

OffscreenTarget::Attachment OffscreenTarget::createAttachment(VkFormat format, VkImageUsageFlags usage,
                                                              VkSampleCountFlagBits samples,
                                                              VkImageAspectFlags aspect) {
  Attachment a;
  VkImageCreateInfo info{VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO};
  info.imageType = VK_IMAGE_TYPE_2D;
  info.format = format;
  info.extent = {width_, height_, 1};
  info.mipLevels = 1;
  info.arrayLayers = 1;
  info.samples = samples;
  info.tiling = VK_IMAGE_TILING_OPTIMAL;
  info.usage = usage;
  info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  info.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
  check(rd_.vkCreateImage(device_.handle(), &info, nullptr, &a.image), "vkCreateImage");
  VkMemoryRequirements req{};
  rd_.vkGetImageMemoryRequirements(device_.handle(), a.image, &req);
  try {
    a.memory = device_.memory().allocate(req, MemoryUse::DeviceLocal);
    check(rd_.vkBindImageMemory(device_.handle(), a.image, a.memory.memory, a.memory.offset),
          "vkBindImageMemory");
    VkImageViewCreateInfo view{VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO};
    view.image = a.image;
    view.viewType = VK_IMAGE_VIEW_TYPE_2D;
    view.format = format;
    view.subresourceRange = {aspect, 0, 1, 0, 1};
    check(rd_.vkCreateImageView(device_.handle(), &view, nullptr, &a.view), "vkCreateImageView");
  } catch (...) {
    destroy(a);
    throw;
  }
  return a;
}

void OffscreenTarget::destroy(Attachment& a) {
  if (a.view) rd_.vkDestroyImageView(device_.handle(), a.view, nullptr);
  if (a.image) rd_.vkDestroyImage(device_.handle(), a.image, nullptr);
  if (a.memory.memory) device_.memory().free(a.memory);
  a = Attachment{};
}

void OffscreenTarget::begin(VkCommandBuffer cmd, const float clear[3]) const {
  VkClearValue values[3]{};
  values[0].color = {{clear[0], clear[1], clear[2], 1.0f}};
  values[1].depthStencil = {1.0f, 0};
  VkRenderPassBeginInfo begin{VK_STRUCTURE_TYPE_RENDER_PASS_BEGIN_INFO};
  begin.renderPass = renderPass_;
  begin.framebuffer = framebuffer_;
  begin.renderArea = {{0, 0}, {width_, height_}};
  begin.clearValueCount = 2;
  begin.pClearValues = values;
  rd_.vkCmdBeginRenderPass(cmd, &begin, VK_SUBPASS_CONTENTS_INLINE);
  VkViewport viewport{0.0f, 0.0f, float(width_), float(height_), 0.0f, 1.0f};
  VkRect2D scissor{{0, 0}, {width_, height_}};
  rd_.vkCmdSetViewport(cmd, 0, 1, &viewport);
  rd_.vkCmdSetScissor(cmd, 0, 1, &scissor);
}

void OffscreenTarget::end(VkCommandBuffer cmd) const { rd_.vkCmdEndRenderPass(cmd); }

void OffscreenTarget::recordReadback(VkCommandBuffer cmd) const {
  VkBufferImageCopy region{};
  region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
  region.imageExtent = {width_, height_, 1};
  const VkImage source = resolve_.image ? resolve_.image : colour_.image;
  rd_.vkCmdCopyImageToBuffer(cmd, source, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, readback_.handle(), 1,
                             &region);
  VkMemoryBarrier barrier{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
  barrier.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
  barrier.dstAccessMask = VK_ACCESS_HOST_READ_BIT;
  device_.d().vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_HOST_BIT, 0, 1,
                                   &barrier, 0, nullptr, 0, nullptr);
}

Image OffscreenTarget::read() const {
  Image image{width_, height_, std::vector<std::uint8_t>(std::size_t(width_) * height_ * 4)};
  std::memcpy(image.rgba.data(), readback_.mapped(), image.rgba.size());
  return image;
}

}  // namespace blobvk::vk
