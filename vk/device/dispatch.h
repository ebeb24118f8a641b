// A private table of Vulkan entry points loaded through the host's vkGetInstanceProcAddr, so the
// library never depends on global prototypes or on the loader the engine uses (volk, static...).
#pragma once

#include <vulkan/vulkan_core.h>

namespace blobvk::vk {

#define BLOBVK_VK_INSTANCE_FUNCTIONS(X)         \
  X(vkGetDeviceProcAddr)                        \
  X(vkGetPhysicalDeviceProperties)              \
  X(vkGetPhysicalDeviceProperties2)             \
  X(vkGetPhysicalDeviceMemoryProperties)        \
  X(vkGetPhysicalDeviceMemoryProperties2)       \
  X(vkEnumerateDeviceExtensionProperties)       \
  X(vkGetPhysicalDeviceFeatures)                \
  X(vkGetPhysicalDeviceQueueFamilyProperties)

#define BLOBVK_VK_DEVICE_FUNCTIONS(X)  \
  X(vkCreateBuffer)                    \
  X(vkDestroyBuffer)                   \
  X(vkGetBufferMemoryRequirements)     \
  X(vkAllocateMemory)                  \
  X(vkFreeMemory)                      \
  X(vkBindBufferMemory)                \
  X(vkMapMemory)                       \
  X(vkUnmapMemory)                     \
  X(vkFlushMappedMemoryRanges)         \
  X(vkInvalidateMappedMemoryRanges)    \
  X(vkCreateShaderModule)              \
  X(vkDestroyShaderModule)             \
  X(vkCreateDescriptorSetLayout)       \
  X(vkDestroyDescriptorSetLayout)      \
  X(vkCreatePipelineLayout)            \
  X(vkDestroyPipelineLayout)           \
  X(vkCreateComputePipelines)          \
  X(vkDestroyPipeline)                 \
  X(vkCreatePipelineCache)             \
  X(vkDestroyPipelineCache)            \
  X(vkGetPipelineCacheData)            \
  X(vkCreateDescriptorPool)            \
  X(vkDestroyDescriptorPool)           \
  X(vkResetDescriptorPool)             \
  X(vkAllocateDescriptorSets)          \
  X(vkUpdateDescriptorSets)            \
  X(vkCreateCommandPool)               \
  X(vkDestroyCommandPool)              \
  X(vkResetCommandPool)                \
  X(vkAllocateCommandBuffers)          \
  X(vkFreeCommandBuffers)              \
  X(vkBeginCommandBuffer)              \
  X(vkEndCommandBuffer)                \
  X(vkCmdBindPipeline)                 \
  X(vkCmdBindDescriptorSets)           \
  X(vkCmdPushConstants)                \
  X(vkCmdDispatch)                     \
  X(vkCmdDispatchIndirect)             \
  X(vkCmdPipelineBarrier)              \
  X(vkCmdCopyBuffer)                   \
  X(vkCmdFillBuffer)                   \
  X(vkCmdWriteTimestamp)               \
  X(vkCmdResetQueryPool)               \
  X(vkCreateQueryPool)                 \
  X(vkDestroyQueryPool)                \
  X(vkGetQueryPoolResults)             \
  X(vkCreateFence)                     \
  X(vkDestroyFence)                    \
  X(vkWaitForFences)                   \
  X(vkResetFences)                     \
  X(vkGetFenceStatus)                  \
  X(vkCreateEvent)                     \
  X(vkDestroyEvent)                    \
  X(vkGetEventStatus)                  \
  X(vkResetEvent)                      \
  X(vkCmdSetEvent)                     \
  X(vkQueueSubmit)

struct Dispatch {
#define BLOBVK_VK_MEMBER(name) PFN_##name name = nullptr;
  BLOBVK_VK_INSTANCE_FUNCTIONS(BLOBVK_VK_MEMBER)
  BLOBVK_VK_DEVICE_FUNCTIONS(BLOBVK_VK_MEMBER)
#undef BLOBVK_VK_MEMBER
};

// Loads every entry point; throws VulkanError naming the first one the driver lacks.
Dispatch loadDispatch(PFN_vkGetInstanceProcAddr getInstanceProcAddr, VkInstance instance,
                      VkDevice device);

}  // namespace blobvk::vk
