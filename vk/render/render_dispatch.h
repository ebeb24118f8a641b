// Graphics and image entry points the renderer needs on top of the compute table (dispatch.h),
// loaded the same way: through the host's vkGetInstanceProcAddr and vkGetDeviceProcAddr, so the
// renderer works with whatever loader the engine uses. All are Vulkan 1.0 core.
#pragma once

#include "blobvk/vk/device/dispatch.h"

namespace blobvk::vk {

#define BLOBVK_VK_RENDER_FUNCTIONS(X)    \
  X(vkGetPhysicalDeviceFormatProperties) \
  X(vkCreateImage)                       \
  X(vkDestroyImage)                      \
  X(vkGetImageMemoryRequirements)        \
  X(vkBindImageMemory)                   \
  X(vkCreateImageView)                   \
  X(vkDestroyImageView)                  \
  X(vkCreateRenderPass)                  \
  X(vkDestroyRenderPass)                 \
  X(vkCreateFramebuffer)                 \
  X(vkDestroyFramebuffer)                \
  X(vkCreateGraphicsPipelines)           \
  X(vkCmdBeginRenderPass)                \
  X(vkCmdEndRenderPass)                  \
  X(vkCmdBindVertexBuffers)              \
  X(vkCmdBindIndexBuffer)                \
  X(vkCmdDrawIndexed)                    \
  X(vkCmdDrawIndexedIndirect)            \
  X(vkCmdSetViewport)                    \
  X(vkCmdSetScissor)                     \
  X(vkCmdCopyImageToBuffer)

struct RenderDispatch {
#define BLOBVK_VK_MEMBER(name) PFN_##name name = nullptr;
  BLOBVK_VK_RENDER_FUNCTIONS(BLOBVK_VK_MEMBER)
#undef BLOBVK_VK_MEMBER
};

// Loads every entry point above for `device`; throws VulkanError naming a missing one.
RenderDispatch loadRenderDispatch(PFN_vkGetInstanceProcAddr getInstanceProcAddr,
                                  VkInstance instance, VkDevice device);

}  // namespace blobvk::vk
