// An offscreen framebuffer: a colour attachment (MSAA when asked and supported) resolved into a
// single-sample RGBA8 image, a depth attachment, the render pass and framebuffer over them, and a
// host-visible buffer the resolved image is copied into for read-back.
//
// Render pass contract: colour, depth and resolve start UNDEFINED (cleared / overwritten); the
// resolved image ends in TRANSFER_SRC_OPTIMAL. An external dependency orders the previous use
// of the target (attachment writes, the transfer read of the last copy) before this pass, and the
// pass's colour writes before a later transfer read (recordReadback).
#pragma once

#include "blobvk/vk/device/context.h"
#include "blobvk/vk/render/render_dispatch.h"
#include "blobvk/vk/render/render_image.h"

#include <cstdint>

namespace blobvk::vk {

class OffscreenTarget {
 public:
  // `samples` is clamped to the largest supported count not above it (1, 2, 4, 8).
  OffscreenTarget(Device& device, const RenderDispatch& rd, std::uint32_t width,
                  std::uint32_t height, std::uint32_t samples);
  ~OffscreenTarget();
  OffscreenTarget(const OffscreenTarget&) = delete;
  OffscreenTarget& operator=(const OffscreenTarget&) = delete;

  std::uint32_t width() const { return width_; }
  std::uint32_t height() const { return height_; }
  VkSampleCountFlagBits samples() const { return samples_; }
  VkRenderPass renderPass() const { return renderPass_; }
  VkFramebuffer framebuffer() const { return framebuffer_; }

  // Begins the render pass with `clear` (RGB in [0, 1], written as-is) and sets viewport/scissor.
  void begin(VkCommandBuffer cmd, const float clear[3]) const;
  void end(VkCommandBuffer cmd) const;
  // Copies the resolved image into the read-back buffer, then a transfer->host barrier.
  void recordReadback(VkCommandBuffer cmd) const;
  // The read-back buffer's contents (after the command buffer has completed).
  Image read() const;

 private:
  struct Attachment {
    VkImage image = VK_NULL_HANDLE;
    VkImageView view = VK_NULL_HANDLE;
    Allocation memory{};
  };
  Attachment createAttachment(VkFormat format, VkImageUsageFlags usage, VkSampleCountFlagBits samples,
                              VkImageAspectFlags aspect);
  void destroy(Attachment& a);
  void release();

  Device& device_;
  const RenderDispatch& rd_;
  std::uint32_t width_, height_;
  VkSampleCountFlagBits samples_ = VK_SAMPLE_COUNT_1_BIT;
  VkFormat depthFormat_ = VK_FORMAT_UNDEFINED;
  Attachment colour_, depth_, resolve_;
  VkRenderPass renderPass_ = VK_NULL_HANDLE;
  VkFramebuffer framebuffer_ = VK_NULL_HANDLE;
  Buffer readback_;
};

VkSampleCountFlagBits supportedSamples(const Device& device, std::uint32_t wanted);

}  // namespace blobvk::vk
