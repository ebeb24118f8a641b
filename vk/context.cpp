#include "vk/context.h"

#include "vk/error.h"
#include "vk/shader_registry.h"

#include <algorithm>
#include <cstring>

namespace blobvk::vk {

Buffer& Buffer::operator=(Buffer&& o) noexcept {
  if (this != &o) {
    if (device_) device_->destroyBuffer(*this);
    device_ = o.device_;
    buffer_ = o.buffer_;
    size_ = o.size_;
    allocation_ = o.allocation_;
    o.device_ = nullptr;
    o.buffer_ = VK_NULL_HANDLE;
    o.allocation_ = {};
  }
  return *this;
}

Buffer::~Buffer() {
  if (device_) device_->destroyBuffer(*this);
}

Device::Device(const HostContext& host) : host_(host) {
  if (!host.device || !host.physicalDevice || !host.instance || !host.queue) {
    throw VulkanError("HostContext needs instance, physicalDevice, device and queue");
  }
  d_ = loadDispatch(host.getInstanceProcAddr, host.instance, host.device);

  VkPhysicalDeviceSubgroupProperties subgroup{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SUBGROUP_PROPERTIES};
  VkPhysicalDeviceProperties2 props{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2};
  props.pNext = &subgroup;
  d_.vkGetPhysicalDeviceProperties2(host.physicalDevice, &props);
  info_.name = props.properties.deviceName;
  info_.type = props.properties.deviceType;
  info_.apiVersion = props.properties.apiVersion;
  info_.subgroupSize = subgroup.subgroupSize;
  info_.limits = props.properties.limits;
  if (VK_API_VERSION_MINOR(info_.apiVersion) < 1 && VK_API_VERSION_MAJOR(info_.apiVersion) == 1) {
    throw VulkanError("device '" + info_.name + "' supports only Vulkan 1.0; blobvk needs 1.1");
  }
  std::uint32_t familyCount = 0;
  d_.vkGetPhysicalDeviceQueueFamilyProperties(host.physicalDevice, &familyCount, nullptr);
  std::vector<VkQueueFamilyProperties> families(familyCount);
  d_.vkGetPhysicalDeviceQueueFamilyProperties(host.physicalDevice, &familyCount, families.data());
  if (host.queueFamilyIndex >= familyCount ||
      !(families[host.queueFamilyIndex].queueFlags & VK_QUEUE_COMPUTE_BIT)) {
    throw VulkanError("HostContext.queueFamilyIndex does not support compute");
  }
  if (families[host.queueFamilyIndex].timestampValidBits > 0) {
    timestampPeriod_ = props.properties.limits.timestampPeriod;
  }

  memory_ = std::make_unique<MemoryAllocator>(d_, host.physicalDevice, host.device);

  VkPipelineCacheCreateInfo cacheInfo{VK_STRUCTURE_TYPE_PIPELINE_CACHE_CREATE_INFO};
  check(d_.vkCreatePipelineCache(host.device, &cacheInfo, nullptr, &pipelineCache_),
        "vkCreatePipelineCache");
  VkCommandPoolCreateInfo poolInfo{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
  poolInfo.flags = VK_COMMAND_POOL_CREATE_TRANSIENT_BIT;
  poolInfo.queueFamilyIndex = host.queueFamilyIndex;
  check(d_.vkCreateCommandPool(host.device, &poolInfo, nullptr, &commandPool_),
        "vkCreateCommandPool");
  VkFenceCreateInfo fenceInfo{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
  check(d_.vkCreateFence(host.device, &fenceInfo, nullptr, &fence_), "vkCreateFence");
}

Device::~Device() {
  d_.vkDeviceWaitIdle(host_.device);
  for (auto& [name, k] : kernels_) {
    d_.vkDestroyPipeline(host_.device, k.pipeline, nullptr);
    d_.vkDestroyPipelineLayout(host_.device, k.layout, nullptr);
    d_.vkDestroyDescriptorSetLayout(host_.device, k.setLayout, nullptr);
  }
  d_.vkDestroyFence(host_.device, fence_, nullptr);
  d_.vkDestroyCommandPool(host_.device, commandPool_, nullptr);
  d_.vkDestroyPipelineCache(host_.device, pipelineCache_, nullptr);
  memory_.reset();
}

Buffer Device::createBuffer(VkDeviceSize size, MemoryUse use, VkBufferUsageFlags extraUsage) {
  size = std::max<VkDeviceSize>(size, 16);
  if (size > info_.limits.maxStorageBufferRange && use == MemoryUse::DeviceLocal) {
    throw VulkanError("buffer of " + std::to_string(size) + " bytes exceeds maxStorageBufferRange (" +
                      std::to_string(info_.limits.maxStorageBufferRange) +
                      "): use smaller bricks");
  }
  VkBufferCreateInfo info{VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
  info.size = size;
  info.usage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT |
               VK_BUFFER_USAGE_TRANSFER_DST_BIT | extraUsage;
  info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  Buffer b;
  check(d_.vkCreateBuffer(host_.device, &info, nullptr, &b.buffer_), "vkCreateBuffer");
  b.device_ = this;
  b.size_ = size;
  VkMemoryRequirements req;
  d_.vkGetBufferMemoryRequirements(host_.device, b.buffer_, &req);
  b.allocation_ = memory_->allocate(req, use);
  check(d_.vkBindBufferMemory(host_.device, b.buffer_, b.allocation_.memory, b.allocation_.offset),
        "vkBindBufferMemory");
  // forceStaging: pretend device memory is not mappable, so data goes through staging copies.
  if (forceStaging_ && use == MemoryUse::DeviceLocal) b.allocation_.mapped = nullptr;
  return b;
}

void Device::destroyBuffer(Buffer& b) {
  if (b.buffer_) d_.vkDestroyBuffer(host_.device, b.buffer_, nullptr);
  memory_->free(b.allocation_);
  b.buffer_ = VK_NULL_HANDLE;
  b.allocation_ = {};
  b.device_ = nullptr;
}

void Device::upload(Buffer& dst, const void* data, VkDeviceSize bytes, VkDeviceSize offset) {
  if (bytes == 0) return;
  if (dst.mapped()) {
    std::memcpy(static_cast<char*>(dst.mapped()) + offset, data, bytes);
    return;
  }
  Buffer staging = createBuffer(bytes, MemoryUse::HostVisible);
  std::memcpy(staging.mapped(), data, bytes);
  submitAndWait([&](VkCommandBuffer cmd) {
    VkBufferCopy region{0, offset, bytes};
    d_.vkCmdCopyBuffer(cmd, staging.handle(), dst.handle(), 1, &region);
  });
}

void Device::download(const Buffer& src, void* data, VkDeviceSize bytes, VkDeviceSize offset) {
  if (bytes == 0) return;
  if (src.mapped()) {
    std::memcpy(data, static_cast<const char*>(src.mapped()) + offset, bytes);
    return;
  }
  Buffer staging = createBuffer(bytes, MemoryUse::HostVisible);
  submitAndWait([&](VkCommandBuffer cmd) {
    VkBufferCopy region{offset, 0, bytes};
    d_.vkCmdCopyBuffer(cmd, src.handle(), staging.handle(), 1, &region);
    VkMemoryBarrier barrier{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
    barrier.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
    barrier.dstAccessMask = VK_ACCESS_HOST_READ_BIT;
    d_.vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_HOST_BIT, 0, 1,
                            &barrier, 0, nullptr, 0, nullptr);
  });
  std::memcpy(data, staging.mapped(), bytes);
}

namespace {
std::string kernelKey(const std::string& name, std::span<const std::uint32_t> specs) {
  std::string key = name;
  for (auto s : specs) {
    key.push_back(':');
    key.append(std::to_string(s));
  }
  return key;
}
}  // namespace

const Kernel& Device::kernel(const std::string& shader, std::uint32_t bindings,
                             std::span<const std::uint32_t> specs) {
  const std::string key = kernelKey(shader, specs);
  if (auto it = kernels_.find(key); it != kernels_.end()) return it->second;
  return createKernel(key, shader, shaderCode(shader), bindings, specs);
}

const Kernel* Device::findKernel(const std::string& name, std::span<const std::uint32_t> specs) const {
  auto it = kernels_.find(kernelKey(name, specs));
  return it == kernels_.end() ? nullptr : &it->second;
}

const Kernel& Device::kernel(const std::string& name, std::span<const std::uint32_t> code,
                             std::uint32_t bindings, std::span<const std::uint32_t> specs) {
  const std::string key = kernelKey(name, specs);
  if (auto it = kernels_.find(key); it != kernels_.end()) return it->second;
  return createKernel(key, name, code, bindings, specs);
}

const Kernel& Device::createKernel(const std::string& key, const std::string& shader,
                                   std::span<const std::uint32_t> code, std::uint32_t bindings,
                                   std::span<const std::uint32_t> specs) {
  Kernel k;
  k.bindings = bindings;
  k.workgroupSize = specs.empty() ? 0 : specs[0];
  std::vector<VkDescriptorSetLayoutBinding> b(bindings);
  for (std::uint32_t i = 0; i < bindings; ++i) {
    b[i] = {i, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr};
  }
  VkDescriptorSetLayoutCreateInfo setInfo{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
  setInfo.bindingCount = bindings;
  setInfo.pBindings = b.data();
  check(d_.vkCreateDescriptorSetLayout(host_.device, &setInfo, nullptr, &k.setLayout),
        "vkCreateDescriptorSetLayout");
  VkPushConstantRange range{VK_SHADER_STAGE_COMPUTE_BIT, 0, 128};
  VkPipelineLayoutCreateInfo layoutInfo{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  layoutInfo.setLayoutCount = 1;
  layoutInfo.pSetLayouts = &k.setLayout;
  layoutInfo.pushConstantRangeCount = 1;
  layoutInfo.pPushConstantRanges = &range;
  check(d_.vkCreatePipelineLayout(host_.device, &layoutInfo, nullptr, &k.layout),
        "vkCreatePipelineLayout");

  VkShaderModuleCreateInfo moduleInfo{VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
  moduleInfo.codeSize = code.size_bytes();
  moduleInfo.pCode = code.data();
  VkShaderModule module = VK_NULL_HANDLE;
  check(d_.vkCreateShaderModule(host_.device, &moduleInfo, nullptr, &module),
        "vkCreateShaderModule");
  std::vector<VkSpecializationMapEntry> entries(specs.size());
  for (std::uint32_t i = 0; i < specs.size(); ++i) entries[i] = {i, i * 4u, 4u};
  VkSpecializationInfo spec{std::uint32_t(entries.size()), entries.data(), specs.size_bytes(),
                            specs.data()};
  VkComputePipelineCreateInfo info{VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO};
  info.stage = {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO};
  info.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
  info.stage.module = module;
  info.stage.pName = "main";
  info.stage.pSpecializationInfo = specs.empty() ? nullptr : &spec;
  info.layout = k.layout;
  const VkResult r =
      d_.vkCreateComputePipelines(host_.device, pipelineCache_, 1, &info, nullptr, &k.pipeline);
  d_.vkDestroyShaderModule(host_.device, module, nullptr);
  check(r, ("vkCreateComputePipelines(" + shader + ")").c_str());
  return kernels_.emplace(key, k).first->second;
}

void Device::submitAndWait(const std::function<void(VkCommandBuffer)>& record) {
  VkCommandBufferAllocateInfo alloc{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
  alloc.commandPool = commandPool_;
  alloc.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  alloc.commandBufferCount = 1;
  VkCommandBuffer cmd = VK_NULL_HANDLE;
  check(d_.vkAllocateCommandBuffers(host_.device, &alloc, &cmd), "vkAllocateCommandBuffers");
  struct Free {
    Device* self;
    VkCommandBuffer cmd;
    ~Free() { self->d_.vkFreeCommandBuffers(self->host_.device, self->commandPool_, 1, &cmd); }
  } freeLater{this, cmd};
  VkCommandBufferBeginInfo begin{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
  begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  check(d_.vkBeginCommandBuffer(cmd, &begin), "vkBeginCommandBuffer");
  record(cmd);
  check(d_.vkEndCommandBuffer(cmd), "vkEndCommandBuffer");
  check(d_.vkResetFences(host_.device, 1, &fence_), "vkResetFences");
  VkSubmitInfo submit{VK_STRUCTURE_TYPE_SUBMIT_INFO};
  submit.commandBufferCount = 1;
  submit.pCommandBuffers = &cmd;
  check(d_.vkQueueSubmit(host_.queue, 1, &submit, fence_), "vkQueueSubmit");
  check(d_.vkWaitForFences(host_.device, 1, &fence_, VK_TRUE, UINT64_MAX), "vkWaitForFences");
}

void Device::run(const std::function<void(Recorder&)>& record) {
  std::unique_ptr<Recorder> recorder;
  submitAndWait([&](VkCommandBuffer cmd) {
    recorder = std::make_unique<Recorder>(*this, cmd);
    record(*recorder);
  });
}

Recorder::Recorder(Device& device, VkCommandBuffer cmd) : device_(device), cmd_(cmd) {}

Recorder::~Recorder() {
  for (auto p : pools_) device_.d().vkDestroyDescriptorPool(device_.handle(), p, nullptr);
}

VkDescriptorSet Recorder::allocateSet(VkDescriptorSetLayout layout) {
  constexpr std::uint32_t kSets = 64, kBuffersPerSet = 12;
  if (setsLeft_ == 0) {
    VkDescriptorPoolSize size{VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, kSets * kBuffersPerSet};
    VkDescriptorPoolCreateInfo info{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
    info.maxSets = kSets;
    info.poolSizeCount = 1;
    info.pPoolSizes = &size;
    VkDescriptorPool pool = VK_NULL_HANDLE;
    check(device_.d().vkCreateDescriptorPool(device_.handle(), &info, nullptr, &pool),
          "vkCreateDescriptorPool");
    pools_.push_back(pool);
    setsLeft_ = kSets;
  }
  VkDescriptorSetAllocateInfo info{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
  info.descriptorPool = pools_.back();
  info.descriptorSetCount = 1;
  info.pSetLayouts = &layout;
  VkDescriptorSet set = VK_NULL_HANDLE;
  check(device_.d().vkAllocateDescriptorSets(device_.handle(), &info, &set),
        "vkAllocateDescriptorSets");
  --setsLeft_;
  return set;
}

void Recorder::bind(const Kernel& kernel, std::span<const BufferRange> buffers, const void* push,
                    std::uint32_t pushSize) {
  if (buffers.size() != kernel.bindings) throw VulkanError("kernel binding count mismatch");
  if (pushSize > 128) throw VulkanError("push constants above 128 bytes");
  const auto& d = device_.d();
  const VkDescriptorSet set = allocateSet(kernel.setLayout);
  std::vector<VkDescriptorBufferInfo> infos(buffers.size());
  std::vector<VkWriteDescriptorSet> writes(buffers.size());
  for (std::size_t i = 0; i < buffers.size(); ++i) {
    infos[i] = {buffers[i].buffer, buffers[i].offset, buffers[i].size};
    writes[i] = {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
    writes[i].dstSet = set;
    writes[i].dstBinding = std::uint32_t(i);
    writes[i].descriptorCount = 1;
    writes[i].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    writes[i].pBufferInfo = &infos[i];
  }
  d.vkUpdateDescriptorSets(device_.handle(), std::uint32_t(writes.size()), writes.data(), 0,
                           nullptr);
  d.vkCmdBindPipeline(cmd_, VK_PIPELINE_BIND_POINT_COMPUTE, kernel.pipeline);
  d.vkCmdBindDescriptorSets(cmd_, VK_PIPELINE_BIND_POINT_COMPUTE, kernel.layout, 0, 1, &set, 0,
                            nullptr);
  if (pushSize) {
    d.vkCmdPushConstants(cmd_, kernel.layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, pushSize, push);
  }
}

void Recorder::dispatch(const Kernel& kernel, std::span<const BufferRange> buffers,
                        const void* push, std::uint32_t pushSize, std::uint32_t groupsX,
                        std::uint32_t groupsY, std::uint32_t groupsZ) {
  bind(kernel, buffers, push, pushSize);
  if (groupsX && groupsY && groupsZ) device_.d().vkCmdDispatch(cmd_, groupsX, groupsY, groupsZ);
}

void Recorder::dispatchIndirect(const Kernel& kernel, std::span<const BufferRange> buffers, const void* push,
                                std::uint32_t pushSize, const Buffer& args, VkDeviceSize offset) {
  bind(kernel, buffers, push, pushSize);
  device_.d().vkCmdDispatchIndirect(cmd_, args.handle(), offset);
}

void Recorder::computeBarrier() {
  VkMemoryBarrier barrier{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
  barrier.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_WRITE_BIT;
  barrier.dstAccessMask = VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT |
                          VK_ACCESS_TRANSFER_READ_BIT | VK_ACCESS_TRANSFER_WRITE_BIT |
                          VK_ACCESS_INDIRECT_COMMAND_READ_BIT;
  device_.d().vkCmdPipelineBarrier(
      cmd_, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT,
      VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT |
          VK_PIPELINE_STAGE_DRAW_INDIRECT_BIT,
      0, 1, &barrier, 0, nullptr, 0, nullptr);
}

void Recorder::hostBarrier() {
  VkMemoryBarrier barrier{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
  barrier.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_WRITE_BIT;
  barrier.dstAccessMask = VK_ACCESS_HOST_READ_BIT;
  device_.d().vkCmdPipelineBarrier(
      cmd_, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT,
      VK_PIPELINE_STAGE_HOST_BIT, 0, 1, &barrier, 0, nullptr, 0, nullptr);
}

void Recorder::fill(const Buffer& b, std::uint32_t value) {
  device_.d().vkCmdFillBuffer(cmd_, b.handle(), 0, VK_WHOLE_SIZE, value);
}

std::uint32_t gridGroupRows(std::uint32_t workgroupSize) {
  return std::max<std::uint32_t>(1, workgroupSize / kGridGroupWidth);
}

Groups3 gridGroups(std::uint32_t nx, std::uint32_t ny, std::uint32_t layers, std::uint32_t workgroupSize) {
  const std::uint32_t rows = gridGroupRows(workgroupSize);
  return {(nx + kGridGroupWidth - 1) / kGridGroupWidth, (ny + rows - 1) / rows, layers};
}

Groups groupsFor(std::uint64_t invocations, std::uint32_t workgroupSize) {
  const std::uint64_t groups = (invocations + workgroupSize - 1) / workgroupSize;
  if (groups == 0) return {0, 0};
  Groups g;
  g.x = std::uint32_t(std::min<std::uint64_t>(groups, 65535));
  g.y = std::uint32_t((groups + g.x - 1) / g.x);
  if (g.y > 65535) throw VulkanError("dispatch too large: use smaller bricks");
  return g;
}

}  // namespace blobvk::vk
