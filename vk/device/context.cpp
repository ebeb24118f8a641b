#include "blobvk/vk/device/context.h"

#include "blobvk/vk/device/error.h"
#include "blobvk/vk/device/shader_layout.h"
#include "blobvk/vk/device/shader_registry.h"

#include <algorithm>
#include <chrono>
#include <cstring>
#include <string>
#include <thread>

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

Device::Device(const HostContext& host, const DeviceOptions& options)
    : host_(host), kernelCapacity_(std::max<std::uint32_t>(1, options.pipelineCacheCapacity)),
      spirvCacheDir_(options.spirvCacheDir) {
  if (!host.device || !host.physicalDevice || !host.instance || !host.queue) {
    throw VulkanError("HostContext needs instance, physicalDevice, device and queue");
  }
  const auto below11 = [](std::uint32_t v) { return VK_API_VERSION_MAJOR(v) < 1 || (VK_API_VERSION_MAJOR(v) == 1 && VK_API_VERSION_MINOR(v) < 1); };
  if (host.instanceApiVersion == 0) {
    throw VulkanError("HostContext.instanceApiVersion is not set: give the VkApplicationInfo::apiVersion the instance "
                      "was created with (blobvk needs VK_API_VERSION_1_1 or later)");
  }
  if (below11(host.instanceApiVersion)) {
    throw VulkanError("the VkInstance was created for Vulkan " + std::to_string(VK_API_VERSION_MAJOR(host.instanceApiVersion)) +
                      "." + std::to_string(VK_API_VERSION_MINOR(host.instanceApiVersion)) +
                      " (HostContext.instanceApiVersion); blobvk needs 1.1: create it with VkApplicationInfo::apiVersion "
                      ">= VK_API_VERSION_1_1");
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
  if (below11(info_.apiVersion)) {
    throw VulkanError("device '" + info_.name + "' supports only Vulkan 1.0; blobvk needs 1.1");
  }
  // The kernels vote across a subgroup (GL_KHR_shader_subgroup_vote: box skips, the classification's
  // tiles); Vulkan 1.1 guarantees only the basic subgroup operations, in compute.
  if (!(subgroup.supportedOperations & VK_SUBGROUP_FEATURE_VOTE_BIT) ||
      !(subgroup.supportedStages & VK_SHADER_STAGE_COMPUTE_BIT)) {
    throw VulkanError("device '" + info_.name + "' has no subgroup vote operations in compute shaders "
                      "(VkPhysicalDeviceSubgroupProperties); blobvk's kernels need them");
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

  memory_ = std::make_unique<MemoryAllocator>(d_, host.physicalDevice, host.device, 64ull << 20,
                                              options.memorySimulation);
  std::uint64_t retain = options.retainedMemoryBytes, retainDevice = retain;
  if (retain == DeviceOptions::kAutoRetain || retain == DeviceOptions::kAutoRetainOwnedDevice) {
    VkDeviceSize largestLocalHeap = 0, largestHostHeap = 0;
    const auto& mp = memory_->properties();
    for (std::uint32_t h = 0; h < mp.memoryHeapCount; ++h) {
      VkDeviceSize& largest = mp.memoryHeaps[h].flags & VK_MEMORY_HEAP_DEVICE_LOCAL_BIT ? largestLocalHeap : largestHostHeap;
      largest = std::max(largest, mp.memoryHeaps[h].size);
    }
    const std::uint64_t quarter = options.memorySimulation ? 0 : largestLocalHeap / 4;
    if (options.retainedMemoryBytes == DeviceOptions::kAutoRetain) {
      retain = retainDevice = std::min<std::uint64_t>(quarter, 1ull << 30);
    } else {
      // Pinned host memory beside a discrete GPU: a sixteenth of the system heap (a 2048^3 job's
      // read-back buffers, 0.5-1.3 GB each, cost 0.25-0.6 s to pin afresh on an H200 host).
      retainDevice = quarter;
      retain = std::min<std::uint64_t>(
          {quarter, std::max<std::uint64_t>(1ull << 30, largestHostHeap / 16), std::uint64_t(8) << 30});
    }
  }
  memory_->setRetainLimits(retain, retainDevice);

  if (host.pipelineCache) {
    pipelineCache_ = host.pipelineCache;
  } else {
    VkPipelineCacheCreateInfo cacheInfo{VK_STRUCTURE_TYPE_PIPELINE_CACHE_CREATE_INFO};
    cacheInfo.initialDataSize = options.pipelineCacheData.size();
    cacheInfo.pInitialData = options.pipelineCacheData.empty() ? nullptr : options.pipelineCacheData.data();
    check(d_.vkCreatePipelineCache(host.device, &cacheInfo, nullptr, &pipelineCache_),
          "vkCreatePipelineCache");
    ownsPipelineCache_ = true;
  }
  VkCommandPoolCreateInfo poolInfo{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
  poolInfo.flags = VK_COMMAND_POOL_CREATE_TRANSIENT_BIT;
  poolInfo.queueFamilyIndex = host.queueFamilyIndex;
  check(d_.vkCreateCommandPool(host.device, &poolInfo, nullptr, &commandPool_),
        "vkCreateCommandPool");
  VkFenceCreateInfo fenceInfo{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
  check(d_.vkCreateFence(host.device, &fenceInfo, nullptr, &fence_), "vkCreateFence");
}

Device::~Device() {
  // Only blobvk's own work is waited for: its one fence, pending only when a submit's wait
  // failed. The host's device and queue are the host's business (no vkDeviceWaitIdle). The
  // kernels only the cache holds are destroyed here; one a pass still holds goes with its last
  // holder.
  waitForBackgroundBuilds();
  if (fencePending_) (void)d_.vkWaitForFences(host_.device, 1, &fence_, VK_TRUE, UINT64_MAX);
  kernels_.clear();
  kernelLru_.clear();
  d_.vkDestroyFence(host_.device, fence_, nullptr);
  for (VkEvent e : hostEvents_) d_.vkDestroyEvent(host_.device, e, nullptr);
  d_.vkDestroyCommandPool(host_.device, commandPool_, nullptr);
  if (ownsPipelineCache_) d_.vkDestroyPipelineCache(host_.device, pipelineCache_, nullptr);
  memory_.reset();
}

std::vector<std::uint8_t> Device::pipelineCacheData() {
  waitForBackgroundBuilds();  // what they build belongs in the data
  std::size_t size = 0;
  check(d_.vkGetPipelineCacheData(host_.device, pipelineCache_, &size, nullptr), "vkGetPipelineCacheData");
  std::vector<std::uint8_t> data(size);
  // VK_INCOMPLETE only if the cache grew in between (another thread of the host using it).
  const VkResult r = d_.vkGetPipelineCacheData(host_.device, pipelineCache_, &size, data.data());
  if (r != VK_INCOMPLETE) check(r, "vkGetPipelineCacheData");
  data.resize(size);
  return data;
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
  if (forceStaging_ && use == MemoryUse::DeviceLocal) {
    b.allocation_.mapped = nullptr;
    b.allocation_.hostCached = false;
  }
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
  Buffer staging = createBuffer(bytes, MemoryUse::Upload);
  std::memcpy(staging.mapped(), data, bytes);
  const VkBufferCopy region{0, offset, bytes};
  if (uploadBatch_) {
    uploadBatch_->copies_.push_back({staging.handle(), dst.handle(), region});
    uploadBatch_->staging_.push_back(std::move(staging));
    return;
  }
  submitAndWait([&](VkCommandBuffer cmd) {
    // Earlier submits' shader and transfer accesses to dst end before the copy writes it.
    VkMemoryBarrier barrier{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
    barrier.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_WRITE_BIT;
    barrier.dstAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
    d_.vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT,
                            VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 1, &barrier, 0, nullptr, 0, nullptr);
    d_.vkCmdCopyBuffer(cmd, staging.handle(), dst.handle(), 1, &region);
  });
}

void Device::download(const Buffer& src, void* data, VkDeviceSize bytes, VkDeviceSize offset) {
  if (bytes == 0) return;
  if (src.mapped() && src.allocation_.hostCached) {
    std::memcpy(data, static_cast<const char*>(src.mapped()) + offset, bytes);
    return;
  }
  Buffer staging = createBuffer(bytes, MemoryUse::Readback);
  submitAndWait([&](VkCommandBuffer cmd) {
    // Earlier submits' writes to src are visible to the copy that reads it.
    VkMemoryBarrier before{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
    before.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_WRITE_BIT;
    before.dstAccessMask = VK_ACCESS_TRANSFER_READ_BIT;
    d_.vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT,
                            VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 1, &before, 0, nullptr, 0, nullptr);
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

UploadBatch::UploadBatch(Device& device) : device_(device), previous_(device.uploadBatch_) {
  device.uploadBatch_ = this;
}

UploadBatch::~UploadBatch() {
  device_.uploadBatch_ = previous_;
}

void UploadBatch::record(VkCommandBuffer cmd) {
  if (copies_.empty()) return;
  const Dispatch& d = device_.d();
  for (const Copy& c : copies_) d.vkCmdCopyBuffer(cmd, c.src, c.dst, 1, &c.region);
  copies_.clear();
  VkMemoryBarrier barrier{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
  barrier.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
  barrier.dstAccessMask = VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_READ_BIT |
                          VK_ACCESS_TRANSFER_WRITE_BIT;
  d.vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT,
                         VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 1, &barrier, 0,
                         nullptr, 0, nullptr);
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

thread_local bool inBackgroundBuild = false;  // createKernel tells the observer nothing there
}  // namespace

void Device::setKernelObserver(std::function<void(KernelRecipe)> observer) {
  std::lock_guard lock(observerMutex_);
  observer_ = std::move(observer);
}

KernelPtr Device::touch(const std::string& key) {
  std::lock_guard lock(kernelMutex_);
  auto it = kernels_.find(key);
  if (it == kernels_.end()) return nullptr;
  kernelLru_.splice(kernelLru_.begin(), kernelLru_, it->second);  // most recently used
  return it->second->second;
}

KernelPtr Device::kernel(const std::string& shader, std::span<const std::uint32_t> specs) {
  const std::string key = kernelKey(shader, specs);
  if (KernelPtr k = touch(key)) return k;
  return createKernel(key, shader, shaderCode(shader), shader, specs);
}

KernelPtr Device::findKernel(const std::string& name, std::span<const std::uint32_t> specs) {
  return touch(kernelKey(name, specs));
}

void Device::buildInBackground(const std::string& key, std::function<void()> build) {
  std::lock_guard lock(kernelMutex_);
  for (const auto& b : backgroundBuilds_)
    if (b.first == key) return;
  // At the process's priority: a lower one (nice 10) made the first job faster on a busy machine
  // but starved the build, and the next job waited for it for tens of seconds.
  backgroundBuilds_.emplace_back(key, std::async(std::launch::async, [build = std::move(build), gate = buildGate_] {
    if (gate.valid()) gate.wait();
    inBackgroundBuild = true;
    try {
      build();
    } catch (...) {  // the next job to need the kernel builds it in the foreground and reports
    }
  }).share());
}

std::size_t Device::backgroundBuildsStarted() const {
  std::lock_guard lock(kernelMutex_);
  return backgroundBuilds_.size();
}

bool Device::backgroundBuildStarted(const std::string& key) const {
  std::lock_guard lock(kernelMutex_);
  for (const auto& b : backgroundBuilds_)
    if (b.first == key) return true;
  return false;
}

bool Device::backgroundBuildDone(const std::string& key) const {
  std::lock_guard lock(kernelMutex_);
  for (const auto& b : backgroundBuilds_)
    if (b.first == key) return b.second.wait_for(std::chrono::seconds(0)) == std::future_status::ready;
  return false;
}

void Device::holdBackgroundBuilds(bool hold) {
  std::lock_guard lock(kernelMutex_);
  if (hold && !buildHold_) {
    buildHold_ = std::make_shared<std::promise<void>>();
    buildGate_ = buildHold_->get_future().share();
  } else if (!hold && buildHold_) {
    buildHold_->set_value();
    buildHold_.reset();
    buildGate_ = {};
  }
}

bool Device::waitForBackgroundBuild(const std::string& key) {
  holdBackgroundBuilds(false);
  std::shared_future<void> build;
  {
    std::lock_guard lock(kernelMutex_);
    for (const auto& b : backgroundBuilds_)
      if (b.first == key) build = b.second;
  }
  if (!build.valid()) return false;
  build.wait();
  return true;
}

void Device::waitForBackgroundBuilds() {
  holdBackgroundBuilds(false);
  std::vector<std::shared_future<void>> builds;
  {
    std::lock_guard lock(kernelMutex_);
    for (const auto& b : backgroundBuilds_) builds.push_back(b.second);
  }
  for (const auto& b : builds) b.wait();
}

KernelPtr Device::kernel(const std::string& name, std::span<const std::uint32_t> code, const std::string& layoutOf,
                         std::span<const std::uint32_t> specs) {
  const std::string key = kernelKey(name, specs);
  if (KernelPtr k = touch(key)) return k;
  return createKernel(key, name, code, layoutOf, specs);
}

KernelPtr Device::createKernel(const std::string& key, const std::string& shader, std::span<const std::uint32_t> code,
                               const std::string& layoutOf, std::span<const std::uint32_t> specs) {
  const ShaderLayout* reflected = findShaderLayout(layoutOf);
  if (!reflected) throw VulkanError("no reflected layout for shader '" + layoutOf + "'");
  // The Vulkan objects die with the last holder of the kernel (the cache, a Recorder, a pass),
  // which may outlive this Device (not the VkDevice): the deleter keeps its own entry points.
  const auto destroyPipeline = d_.vkDestroyPipeline;
  const auto destroyLayout = d_.vkDestroyPipelineLayout;
  const auto destroySetLayout = d_.vkDestroyDescriptorSetLayout;
  const VkDevice device = host_.device;
  std::shared_ptr<Kernel> k(new Kernel, [=](Kernel* p) {
    if (p->pipeline) destroyPipeline(device, p->pipeline, nullptr);
    if (p->layout) destroyLayout(device, p->layout, nullptr);
    if (p->setLayout) destroySetLayout(device, p->setLayout, nullptr);
    delete p;
  });
  k->shaderLayout = reflected;
  k->bindings = std::uint32_t(reflected->bindings.size());
  k->pushConstantBytes = reflected->pushConstantBytes;
  k->pushConstantRange = std::min<std::uint32_t>((reflected->pushConstantBytes + 15) / 16 * 16, 128);
  k->workgroupSize = specs.empty() ? 0 : specs[0];
  std::vector<VkDescriptorSetLayoutBinding> b(k->bindings);
  for (std::uint32_t i = 0; i < k->bindings; ++i) {
    b[i] = {i, reflected->bindings[i].type, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr};
  }
  VkDescriptorSetLayoutCreateInfo setInfo{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
  setInfo.bindingCount = k->bindings;
  setInfo.pBindings = b.data();
  check(d_.vkCreateDescriptorSetLayout(host_.device, &setInfo, nullptr, &k->setLayout),
        "vkCreateDescriptorSetLayout");
  VkPushConstantRange range{VK_SHADER_STAGE_COMPUTE_BIT, 0, k->pushConstantRange};
  VkPipelineLayoutCreateInfo layoutInfo{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  layoutInfo.setLayoutCount = 1;
  layoutInfo.pSetLayouts = &k->setLayout;
  layoutInfo.pushConstantRangeCount = k->pushConstantRange ? 1 : 0;
  layoutInfo.pPushConstantRanges = &range;
  check(d_.vkCreatePipelineLayout(host_.device, &layoutInfo, nullptr, &k->layout),
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
  info.layout = k->layout;
  const auto buildStart = std::chrono::steady_clock::now();
  const VkResult r =
      d_.vkCreateComputePipelines(host_.device, pipelineCache_, 1, &info, nullptr, &k->pipeline);
  const double buildSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - buildStart).count();
  d_.vkDestroyShaderModule(host_.device, module, nullptr);
  check(r, ("vkCreateComputePipelines(" + shader + ")").c_str());

  {
    std::lock_guard lock(kernelMutex_);
    // Another thread may have built the same kernel meanwhile: keep the first (ours dies here).
    if (auto it = kernels_.find(key); it != kernels_.end()) return it->second->second;
    cacheKernel(key, layoutOf, k);
  }
  if (!inBackgroundBuild) {
    std::lock_guard lock(observerMutex_);
    if (observer_)
      observer_(KernelRecipe{shader, layoutOf, {code.begin(), code.end()}, {specs.begin(), specs.end()}, k, buildSeconds});
  }
  return k;
}

void Device::cacheKernel(const std::string& key, const std::string& layoutOf, const KernelPtr& k) {
  if (std::find(shadersUsed_.begin(), shadersUsed_.end(), layoutOf) == shadersUsed_.end()) {
    shadersUsed_.push_back(layoutOf);
  }
  // Least recently used out: holders elsewhere keep theirs alive until they let go.
  while (kernelLru_.size() >= kernelCapacity_) {
    kernels_.erase(kernelLru_.back().first);
    kernelLru_.pop_back();
    ++evictedKernels_;
  }
  kernelLru_.emplace_front(key, k);
  kernels_[key] = kernelLru_.begin();
}

void Device::submitAndWait(const std::function<void(VkCommandBuffer)>& record,
                           const std::function<void()>& whileRunning) {
  if (fencePending_) {  // an earlier wait failed: the fence must signal before it is reused
    check(d_.vkWaitForFences(host_.device, 1, &fence_, VK_TRUE, UINT64_MAX), "vkWaitForFences");
    fencePending_ = false;
  }
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
  if (uploadBatch_) uploadBatch_->record(cmd);  // queued uploads land before what reads them
  record(cmd);
  check(d_.vkEndCommandBuffer(cmd), "vkEndCommandBuffer");
  check(d_.vkResetFences(host_.device, 1, &fence_), "vkResetFences");
  VkSubmitInfo submit{VK_STRUCTURE_TYPE_SUBMIT_INFO};
  submit.commandBufferCount = 1;
  submit.pCommandBuffers = &cmd;
  check(d_.vkQueueSubmit(host_.queue, 1, &submit, fence_), "vkQueueSubmit");
  fencePending_ = true;
  if (whileRunning) {
    try {
      whileRunning();
    } catch (...) {
      // The commands may still use the caller's buffers, which the exception is about to free.
      if (d_.vkWaitForFences(host_.device, 1, &fence_, VK_TRUE, UINT64_MAX) == VK_SUCCESS) fencePending_ = false;
      throw;
    }
  }
  check(d_.vkWaitForFences(host_.device, 1, &fence_, VK_TRUE, UINT64_MAX), "vkWaitForFences");
  fencePending_ = false;
}

void Device::run(const std::function<void(Recorder&)>& record, const std::function<void()>& whileRunning) {
  std::unique_ptr<Recorder> recorder;
  submitAndWait(
      [&](VkCommandBuffer cmd) {
        recorder = std::make_unique<Recorder>(*this, cmd);
        record(*recorder);
      },
      whileRunning);
  recorder->markExecuted();
}

std::span<const VkEvent> Device::hostEvents(std::uint32_t count) {
  if (fencePending_) {  // an earlier wait failed: its commands may still set these events
    check(d_.vkWaitForFences(host_.device, 1, &fence_, VK_TRUE, UINT64_MAX), "vkWaitForFences");
    fencePending_ = false;
  }
  while (hostEvents_.size() < count) {
    VkEventCreateInfo info{VK_STRUCTURE_TYPE_EVENT_CREATE_INFO};
    VkEvent e = VK_NULL_HANDLE;
    check(d_.vkCreateEvent(host_.device, &info, nullptr, &e), "vkCreateEvent");
    hostEvents_.push_back(e);
  }
  for (std::uint32_t i = 0; i < count; ++i) check(d_.vkResetEvent(host_.device, hostEvents_[i]), "vkResetEvent");
  return {hostEvents_.data(), count};
}

void Device::waitForHostEvent(VkEvent event) {
  for (;;) {
    const VkResult r = d_.vkGetEventStatus(host_.device, event);
    if (r == VK_EVENT_SET) return;
    if (r != VK_EVENT_RESET) check(r, "vkGetEventStatus");
    // The run's fence signals after every command, the event's too: a signalled fence with the
    // event unset is a caller's error, and a lost device shows here if not in the event.
    const VkResult f = d_.vkGetFenceStatus(host_.device, fence_);
    if (f == VK_SUCCESS && d_.vkGetEventStatus(host_.device, event) != VK_EVENT_SET)
      throw VulkanError("waitForHostEvent: the run ended without setting the event");
    if (f != VK_SUCCESS && f != VK_NOT_READY) check(f, "vkGetFenceStatus");
    std::this_thread::yield();
  }
}

void Recorder::signalHost(VkEvent event) {
  // vkCmdSetEvent (Vulkan 1.0) orders the signal after the earlier transfers and shaders; the
  // barrier before it makes their writes available to the host (coherent memory: the read-back
  // types blobvk allocates). vkCmdSetEvent2's own dependency would state that in one command
  // but needs Vulkan 1.3 or synchronization2, which the library does not require.
  hostBarrier();
  device_.d().vkCmdSetEvent(cmd_, event, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT);
}

void Recorder::markExecuted() {
  for (const KernelPtr& k : kernels_) k->executed.store(true, std::memory_order_relaxed);
}

Recorder::Recorder(Device& device, VkCommandBuffer cmd) : device_(device), cmd_(cmd) {}

Recorder::~Recorder() {
  for (auto p : pools_) device_.d().vkDestroyDescriptorPool(device_.handle(), p, nullptr);
}

VkDescriptorSet Recorder::allocateSet(const Kernel& kernel) {
  // Pools sized from the reflected layouts: room for kSets sets of the largest binding count
  // any embedded shader declares, refilled when a kernel's bindings no longer fit.
  constexpr std::uint32_t kSets = 64;
  std::uint32_t buffers = 0, uniforms = 0;
  for (const ShaderBinding& b : kernel.shaderLayout->bindings) {
    (b.type == VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER ? uniforms : buffers) += 1;
  }
  if (setsLeft_ == 0 || buffersLeft_ < buffers || uniformsLeft_ < uniforms) {
    std::uint32_t maxBuffers = 1, maxUniforms = 1;
    for (const ShaderLayout& l : shaderLayouts()) {
      std::uint32_t s = 0, u = 0;
      for (const ShaderBinding& b : l.bindings) (b.type == VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER ? u : s) += 1;
      maxBuffers = std::max(maxBuffers, s);
      maxUniforms = std::max(maxUniforms, u);
    }
    const VkDescriptorPoolSize sizes[2] = {{VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, kSets * maxBuffers},
                                           {VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, kSets * maxUniforms}};
    VkDescriptorPoolCreateInfo info{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
    info.maxSets = kSets;
    info.poolSizeCount = 2;
    info.pPoolSizes = sizes;
    VkDescriptorPool pool = VK_NULL_HANDLE;
    check(device_.d().vkCreateDescriptorPool(device_.handle(), &info, nullptr, &pool),
          "vkCreateDescriptorPool");
    pools_.push_back(pool);
    setsLeft_ = kSets;
    buffersLeft_ = kSets * maxBuffers;
    uniformsLeft_ = kSets * maxUniforms;
  }
  VkDescriptorSetAllocateInfo info{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
  info.descriptorPool = pools_.back();
  info.descriptorSetCount = 1;
  info.pSetLayouts = &kernel.setLayout;
  VkDescriptorSet set = VK_NULL_HANDLE;
  check(device_.d().vkAllocateDescriptorSets(device_.handle(), &info, &set),
        "vkAllocateDescriptorSets");
  --setsLeft_;
  buffersLeft_ -= buffers;
  uniformsLeft_ -= uniforms;
  return set;
}

void Recorder::bind(const Kernel& kernel, std::span<const BufferRange> buffers, const void* push,
                    std::uint32_t pushSize) {
  // The C++ side must match what the shader declares (its SPIR-V reflection).
  const char* shader = kernel.shaderLayout ? kernel.shaderLayout->shader : "?";
  if (buffers.size() != kernel.bindings) {
    throw VulkanError(std::string("shader ") + shader + " declares " + std::to_string(kernel.bindings) +
                      " buffer bindings; the dispatch binds " + std::to_string(buffers.size()));
  }
  if (pushSize < kernel.pushConstantBytes || pushSize > kernel.pushConstantRange) {
    throw VulkanError(std::string("shader ") + shader + " declares " + std::to_string(kernel.pushConstantBytes) +
                      " bytes of push constants; the dispatch pushes " + std::to_string(pushSize));
  }
  if (kernels_.empty() || kernels_.back().get() != &kernel) kernels_.push_back(kernel.shared_from_this());
  kernel.recorded.store(true, std::memory_order_relaxed);
  const auto& d = device_.d();
  const VkDescriptorSet set = allocateSet(kernel);
  std::vector<VkDescriptorBufferInfo> infos(buffers.size());
  std::vector<VkWriteDescriptorSet> writes(buffers.size());
  for (std::size_t i = 0; i < buffers.size(); ++i) {
    infos[i] = {buffers[i].buffer, buffers[i].offset, buffers[i].size};
    writes[i] = {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
    writes[i].dstSet = set;
    writes[i].dstBinding = std::uint32_t(i);
    writes[i].descriptorCount = 1;
    writes[i].descriptorType = kernel.shaderLayout->bindings[i].type;
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

void Recorder::copy(const Buffer& src, VkDeviceSize srcOffset, const Buffer& dst, VkDeviceSize dstOffset,
                    VkDeviceSize bytes) {
  if (bytes == 0) return;
  const VkBufferCopy region{srcOffset, dstOffset, bytes};
  device_.d().vkCmdCopyBuffer(cmd_, src.handle(), dst.handle(), 1, &region);
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
