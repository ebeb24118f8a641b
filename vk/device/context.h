// How the library meets a Vulkan device: a HostContext holds the engine's handles (never
// destroyed by us); a Device wraps one with our private dispatch table, memory allocator,
// pipeline cache and a one-shot submit path. StandaloneContext (standalone.h) creates its own.
#pragma once

#include "blobvk/vk/device/dispatch.h"
#include "blobvk/vk/device/memory.h"

#include <atomic>
#include <cstdint>
#include <functional>
#include <list>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <future>
#include <unordered_map>
#include <vector>

namespace blobvk::vk {

// The engine's objects. All must outlive the Device built on them. The device must support
// Vulkan 1.1 and a queue family with compute; no extension or optional feature is needed.
struct HostContext {
  VkInstance instance = VK_NULL_HANDLE;
  VkPhysicalDevice physicalDevice = VK_NULL_HANDLE;
  VkDevice device = VK_NULL_HANDLE;
  std::uint32_t queueFamilyIndex = 0;  // must support VK_QUEUE_COMPUTE_BIT
  VkQueue queue = VK_NULL_HANDLE;      // used by Device::submitAndWait; externally synchronised
  PFN_vkGetInstanceProcAddr getInstanceProcAddr = nullptr;
  // The VkApplicationInfo::apiVersion the instance was created with (an instance created
  // without one is Vulkan 1.0). Required, at least VK_API_VERSION_1_1: the library calls 1.1
  // commands, which a 1.0 instance does not allow whatever the device supports, and a handle
  // cannot tell which version its instance asked for. 0 (not set) is refused with a message.
  std::uint32_t instanceApiVersion = 0;
  // Optional: the engine's VkPipelineCache. When set, blobvk creates every pipeline (compute
  // kernels, the mesh renderer's) with it and never destroys it; persisting it is the engine's
  // business. When null, the Device creates a private one (DeviceOptions::pipelineCacheData).
  VkPipelineCache pipelineCache = VK_NULL_HANDLE;
};

// A device buffer with its memory. Moves, never copies.
class Buffer {
 public:
  Buffer() = default;
  Buffer(Buffer&& o) noexcept { *this = std::move(o); }
  Buffer& operator=(Buffer&& o) noexcept;
  ~Buffer();

  VkBuffer handle() const { return buffer_; }
  VkDeviceSize size() const { return size_; }
  void* mapped() const { return allocation_.mapped; }  // null when not host visible
  // Mapped host-cached memory: the host reads it fast (else read it back through staging).
  bool hostReadable() const { return allocation_.mapped && allocation_.hostCached; }
  std::uint32_t memoryType() const { return allocation_.type; }  // index chosen by the allocator
  explicit operator bool() const { return buffer_ != VK_NULL_HANDLE; }

 private:
  friend class Device;
  class Device* device_ = nullptr;
  VkBuffer buffer_ = VK_NULL_HANDLE;
  VkDeviceSize size_ = 0;
  Allocation allocation_{};
};

// A compute pipeline. Its descriptor-set layout (set 0: one buffer per binding) and push-constant
// range come from the shader's SPIR-V reflection (vk/device/shader_layout.h). Owned by shared pointers:
// the Device's pipeline cache holds one until it evicts the kernel, every holder (a FieldPass, a
// Recorder that bound it) keeps it alive, and the last one destroys its Vulkan objects.
struct Kernel : std::enable_shared_from_this<Kernel> {
  VkDescriptorSetLayout setLayout = VK_NULL_HANDLE;
  VkPipelineLayout layout = VK_NULL_HANDLE;
  VkPipeline pipeline = VK_NULL_HANDLE;
  const struct ShaderLayout* shaderLayout = nullptr;
  std::uint32_t bindings = 0;           // buffers bound at set 0, bindings 0..n-1
  std::uint32_t pushConstantBytes = 0;  // the shader's block; pushes must cover it
  std::uint32_t pushConstantRange = 0;  // the layout's range (the block rounded up to 16 bytes)
  std::uint32_t workgroupSize = 0;
  // Set when a Recorder first binds it (its first dispatch is on its way to the queue), and when
  // a Device::run that bound it has finished on the device (its code has been generated).
  mutable std::atomic<bool> recorded{false}, executed{false};
};
using KernelPtr = std::shared_ptr<const Kernel>;

// A kernel a Device has just built, with what another device needs to build the same pipeline
// (a lavapipe warm-up compiles it elsewhere: vk/extract/kernel_warm_up.h).
struct KernelRecipe {
  std::string name;      // the cache name (an embedded shader's, or a generated kernel's)
  std::string layoutOf;  // the embedded shader whose reflected layout it has
  std::vector<std::uint32_t> code, specs;
  std::weak_ptr<const Kernel> kernel;  // the built kernel (Kernel::recorded, Kernel::executed)
  double buildSeconds = 0.0;           // its vkCreateComputePipelines on this device
};

struct DeviceInfo {
  std::string name;
  VkPhysicalDeviceType type = VK_PHYSICAL_DEVICE_TYPE_OTHER;
  std::uint32_t apiVersion = 0;
  std::uint32_t subgroupSize = 0;
  VkPhysicalDeviceLimits limits{};
  // Mesa's CPU driver under lavapipe, which reports itself as "llvmpipe (LLVM 15.0.6, 256 bits)":
  // its loop limit and its code generation at first dispatch are its own, not every CPU driver's.
  bool isLlvmpipe() const { return name.rfind("llvmpipe", 0) == 0; }
};

// What a Device is created with besides the host's handles (all optional).
struct DeviceOptions {
  // Compute pipelines kept in the Device's cache, least recently used evicted first (a viewer
  // that edits a model builds a specialised kernel per edit). At least 1.
  std::uint32_t pipelineCacheCapacity = 256;
  // Tests: present this memory layout instead of the device's (vk/device/memory.h).
  const MemorySimulation* memorySimulation = nullptr;
  // Initial data of the Device's own VkPipelineCache (what pipelineCacheData() returned in an
  // earlier process; StandaloneContext keeps it on disk). Ignored when the host hands in its own
  // cache. Must begin with a VkPipelineCacheHeaderVersionOne matching the device.
  std::span<const std::uint8_t> pipelineCacheData;
  // Directory of the SPIR-V cache of kernels generated at run time (vk/eval/spirv_cache.h): the
  // part of start-up a driver's pipeline cache does not keep (lavapipe keeps nothing). Empty:
  // none. StandaloneContext uses its pipeline cache directory.
  std::string spirvCacheDir;
  // Freed device memory kept for the next buffers of its size (vk/device/memory.h), so a steady
  // stream of jobs allocates nothing; given back before blobvk's own allocations would fail (not
  // before the host's), and by MemoryAllocator::releaseRetained(). In both pools of
  // MemoryAllocator::setRetainLimits:
  // - kAutoRetain (a device the host application shares with blobvk): a quarter of the largest
  //   device-local heap, at most 1 GiB;
  // - kAutoRetainOwnedDevice (StandaloneContext, whose VkDevice is blobvk's alone): a discrete
  //   GPU's own memory up to that quarter (a 2048^3 job would allocate 10 GB afresh each run),
  //   the host's memory up to the larger of 1 GiB and a sixteenth of a separate system heap, at
  //   most 8 GiB (pinned read-back buffers);
  // none under a memorySimulation, whose tests count allocations. Any other value bounds both
  // pools; 0: none.
  static constexpr std::uint64_t kAutoRetain = ~0ull;
  static constexpr std::uint64_t kAutoRetainOwnedDevice = ~0ull - 1;
  std::uint64_t retainedMemoryBytes = kAutoRetain;
};

class Device {
 public:
  explicit Device(const HostContext& host, const DeviceOptions& options = {});
  ~Device();
  Device(const Device&) = delete;
  Device& operator=(const Device&) = delete;

  const Dispatch& d() const { return d_; }
  VkDevice handle() const { return host_.device; }
  const HostContext& host() const { return host_; }
  const DeviceInfo& info() const { return info_; }
  MemoryAllocator& memory() { return *memory_; }

  // Storage buffer (also transfer src/dst and indirect). `use` picks the memory (vk/device/memory.h).
  Buffer createBuffer(VkDeviceSize size, MemoryUse use = MemoryUse::DeviceLocal,
                      VkBufferUsageFlags extraUsage = 0);
  // Copies host data into a buffer: a memcpy when it is mapped, else through an Upload staging
  // buffer, copied by a one-shot submit or, while an UploadBatch is open, by a copy the batch
  // records into the host's command buffer.
  void upload(Buffer& dst, const void* data, VkDeviceSize bytes, VkDeviceSize offset = 0);
  // Copies a buffer out: a memcpy when it is mapped host-cached memory, else through a Readback
  // staging buffer and a one-shot submit (reading uncached memory is slow on discrete GPUs).
  void download(const Buffer& src, void* data, VkDeviceSize bytes, VkDeviceSize offset = 0);
  // forceStaging: device-local buffers created from now on are not mapped, so data goes through
  // staging copies (the discrete-GPU path on lavapipe; MemorySimulation does the whole layout).
  void setForceStaging(bool on) { forceStaging_ = on; }
  bool forceStaging() const { return forceStaging_; }

  // Kernels may be built on several threads at once (a pass builds its slowest kernel in the
  // background while the device runs the kernels before it): the cache is locked, the pipeline
  // creation is not, and a kernel two threads built at once is kept once.
  // Cached compute pipeline for an embedded shader with specialization constants
  // (constant_id i = specs[i]; constant 0 is the workgroup size by convention). Its layout is
  // the shader's reflected one (vk/device/shader_layout.h).
  KernelPtr kernel(const std::string& shader, std::span<const std::uint32_t> specs);
  // The same for SPIR-V made at run time (vk/eval/runtime_compiler.h) from the embedded shader
  // `layoutOf` (whose reflected layout it shares); `name` must identify the code (e.g. shader +
  // a hash of the source), since pipelines are cached by name and specs.
  KernelPtr kernel(const std::string& name, std::span<const std::uint32_t> code, const std::string& layoutOf,
                   std::span<const std::uint32_t> specs);
  // A cached pipeline, or null (lets callers skip generating code that is already built).
  KernelPtr findKernel(const std::string& name, std::span<const std::uint32_t> specs);
  // Runs `build` (which builds kernels into this cache) on a thread of its own, for a later job:
  // a job that cannot wait for a slow kernel runs another evaluator meanwhile.
  // One build per `key` is started in the Device's life (a key started before is ignored); a
  // build that throws is dropped, so the job that next needs the kernel builds it and sees the
  // error. Background builds are waited for by waitForBackgroundBuilds() and the destructor.
  void buildInBackground(const std::string& key, std::function<void()> build);
  // Background builds started so far (tests); whether the one of `key` was, and has finished
  // (without waiting); a wait for it (false: none was started), and for all of them.
  std::size_t backgroundBuildsStarted() const;
  bool backgroundBuildStarted(const std::string& key) const;
  bool backgroundBuildDone(const std::string& key) const;
  // Tests: while held, background builds started do not begin (a job can then be seen running
  // beside an unfinished build); releasing lets them run. Waits for builds release the hold first.
  void holdBackgroundBuilds(bool hold);
  bool waitForBackgroundBuild(const std::string& key);
  void waitForBackgroundBuilds();
  // Called with each kernel built from now on, on the building thread once it is cached, except
  // the kernels of background builds (for later jobs); null detaches. A call in progress
  // finishes before setKernelObserver returns, so the observer may go once it is detached.
  void setKernelObserver(std::function<void(KernelRecipe)> observer);
  // Pipelines in the cache, and how many it has evicted since creation.
  std::size_t cachedKernels() const {
    std::lock_guard lock(kernelMutex_);
    return kernelLru_.size();
  }
  std::uint64_t evictedKernels() const {
    std::lock_guard lock(kernelMutex_);
    return evictedKernels_;
  }
  // The names of the embedded shaders that kernels were built from (tests of coverage; read it
  // while no kernel is being built).
  const std::vector<std::string>& shadersUsed() const { return shadersUsed_; }

  // Records with `record`, submits to the host queue and waits on blobvk's own fence (never on
  // the host's device or queue). Throws on device loss. `whileRunning`, if any, is host work
  // done between the submit and the wait (it must not touch what the commands use); if it
  // throws, the fence is waited for before the exception leaves.
  void submitAndWait(const std::function<void(VkCommandBuffer)>& record,
                     const std::function<void()>& whileRunning = {});
  // The same with a Recorder that stays alive (with its descriptor sets) until the fence.
  void run(const std::function<void(class Recorder&)>& record, const std::function<void()>& whileRunning = {});
  // `count` events the device sets (Recorder::signalHost) and the host waits for during a run's
  // whileRunning, to use each result as soon as the device has it (the sparse extraction copies
  // each output into the mesh while the device copies out the next). Owned by the Device and
  // reset here: ask for them before recording, use them in one run at a time.
  std::span<const VkEvent> hostEvents(std::uint32_t count);
  // Waits (polling) until the device has set `event`; throws VulkanError on device loss.
  void waitForHostEvent(VkEvent event);

  // The VkPipelineCache every pipeline is created with: the host's, or the Device's own.
  VkPipelineCache pipelineCache() const { return pipelineCache_; }
  bool ownsPipelineCache() const { return ownsPipelineCache_; }
  // vkGetPipelineCacheData of that cache (what to persist for a later process), once the
  // background builds have ended.
  std::vector<std::uint8_t> pipelineCacheData();

  // DeviceOptions::spirvCacheDir.
  const std::string& spirvCacheDir() const { return spirvCacheDir_; }

  // Nanoseconds per timestamp tick; 0 when the queue has no timestamps.
  double timestampPeriodNs() const { return timestampPeriod_; }

  // Per-Device state of the field planner (vk/eval/field.cpp's tile plans): kept here so that two
  // Devices share nothing; type-erased to keep this header light.
  std::shared_ptr<void>& tilePlanCache() { return tilePlanCache_; }

 private:
  friend class Buffer;
  friend class UploadBatch;
  void destroyBuffer(Buffer& b);
  KernelPtr createKernel(const std::string& key, const std::string& shader, std::span<const std::uint32_t> code,
                         const std::string& layoutOf, std::span<const std::uint32_t> specs);
  KernelPtr touch(const std::string& key);
  void cacheKernel(const std::string& key, const std::string& layoutOf, const KernelPtr& k);  // kernelMutex_ held

  HostContext host_;
  Dispatch d_;
  DeviceInfo info_;
  std::unique_ptr<MemoryAllocator> memory_;
  VkPipelineCache pipelineCache_ = VK_NULL_HANDLE;
  bool ownsPipelineCache_ = false;  // false: the host's, never destroyed here
  VkCommandPool commandPool_ = VK_NULL_HANDLE;
  VkFence fence_ = VK_NULL_HANDLE;
  bool fencePending_ = false;  // submitted and not yet seen signalled (an error path)
  std::vector<VkEvent> hostEvents_;
  bool forceStaging_ = false;
  double timestampPeriod_ = 0.0;
  // The pipeline cache: most recently used first; kernelMutex_ guards it and shadersUsed_.
  mutable std::mutex kernelMutex_;
  std::uint32_t kernelCapacity_ = 256;
  std::list<std::pair<std::string, KernelPtr>> kernelLru_;
  std::unordered_map<std::string, std::list<std::pair<std::string, KernelPtr>>::iterator> kernels_;
  std::uint64_t evictedKernels_ = 0;
  // Background builds by key, in start order (kernelMutex_ guards the list, not the waits).
  std::vector<std::pair<std::string, std::shared_future<void>>> backgroundBuilds_;
  std::shared_ptr<std::promise<void>> buildHold_;  // holdBackgroundBuilds; kernelMutex_ guards it
  std::shared_future<void> buildGate_;
  std::vector<std::string> shadersUsed_;
  std::mutex observerMutex_;
  std::function<void(KernelRecipe)> observer_;
  std::shared_ptr<void> tilePlanCache_;
  std::string spirvCacheDir_;
  class UploadBatch* uploadBatch_ = nullptr;  // the open batch, if any
};

// Uploads recorded into the host's command buffer instead of blocking submits. While a batch is
// open on a Device, Device::upload to a buffer that is not host visible (program records,
// tables: everything a SlabPolygonizer, FieldPass or Raycaster uploads at construction) writes
// a staging buffer and queues a copy; record() puts the queued copies into `cmd` followed by
// one barrier: TRANSFER_WRITE -> SHADER_READ | SHADER_WRITE | TRANSFER_READ | TRANSFER_WRITE at
// COMPUTE_SHADER | TRANSFER. Uploads to mapped buffers are plain memcpys and need nothing.
// Keep the batch alive until `cmd` has executed (it owns the staging buffers), and not past its
// Device; batches on one Device close in reverse order of opening. A Device::run or
// submitAndWait while copies are queued records them first in its own command buffer.
class UploadBatch {
 public:
  explicit UploadBatch(Device& device);
  ~UploadBatch();  // closes the batch; copies never recorded are dropped
  UploadBatch(const UploadBatch&) = delete;
  UploadBatch& operator=(const UploadBatch&) = delete;

  void record(VkCommandBuffer cmd);
  std::size_t queuedCopies() const { return copies_.size(); }
  std::size_t stagingBuffers() const { return staging_.size(); }

 private:
  friend class Device;
  struct Copy {
    VkBuffer src, dst;
    VkBufferCopy region;
  };
  Device& device_;
  UploadBatch* previous_;
  std::vector<Buffer> staging_;
  std::vector<Copy> copies_;
};

// The dispatch recorder: binds a kernel, its buffers (through a descriptor pool it owns) and
// push constants. Descriptor sets live until the recorder is destroyed or reset(), so keep it
// alive until the command buffer has executed.
struct BufferRange {
  VkBuffer buffer = VK_NULL_HANDLE;
  VkDeviceSize offset = 0;
  VkDeviceSize size = VK_WHOLE_SIZE;
  BufferRange() = default;
  BufferRange(const Buffer& b) : buffer(b.handle()), offset(0), size(VK_WHOLE_SIZE) {}
  BufferRange(VkBuffer b, VkDeviceSize o, VkDeviceSize s) : buffer(b), offset(o), size(s) {}
};

class Recorder {
 public:
  Recorder(Device& device, VkCommandBuffer cmd);
  ~Recorder();
  Recorder(const Recorder&) = delete;
  Recorder& operator=(const Recorder&) = delete;

  VkCommandBuffer cmd() const { return cmd_; }
  Device& device() { return device_; }

  // Dispatches groups (x, y) of `kernel`; pushSize <= 128.
  void dispatch(const Kernel& kernel, std::span<const BufferRange> buffers, const void* push,
                std::uint32_t pushSize, std::uint32_t groupsX, std::uint32_t groupsY = 1,
                std::uint32_t groupsZ = 1);
  // The same with the group counts read on the device from a VkDispatchIndirectCommand in
  // `args` at `offset` (counts that never come back to the host).
  void dispatchIndirect(const Kernel& kernel, std::span<const BufferRange> buffers, const void* push,
                        std::uint32_t pushSize, const Buffer& args, VkDeviceSize offset);
  // Compute writes -> compute reads/writes, transfers and indirect reads (one global barrier:
  // cheap on every driver and what lavapipe does anyway).
  void computeBarrier();
  // Compute/transfer writes -> host reads, before the fence the host waits on.
  void hostBarrier();
  // hostBarrier, then sets `event` (Device::hostEvents): once the host sees it set
  // (Device::waitForHostEvent), it may read what the commands before it wrote.
  void signalHost(VkEvent event);
  void fill(const Buffer& b, std::uint32_t value);
  void copy(const Buffer& src, VkDeviceSize srcOffset, const Buffer& dst, VkDeviceSize dstOffset,
            VkDeviceSize bytes);

 private:
  friend class Device;
  void markExecuted();  // Device::run, after its fence: every bound kernel has run
  VkDescriptorSet allocateSet(const Kernel& kernel);
  void bind(const Kernel& kernel, std::span<const BufferRange> buffers, const void* push, std::uint32_t pushSize);
  Device& device_;
  VkCommandBuffer cmd_;
  std::vector<VkDescriptorPool> pools_;
  std::uint32_t setsLeft_ = 0, buffersLeft_ = 0, uniformsLeft_ = 0;
  std::vector<KernelPtr> kernels_;  // bound kernels live until the command buffer has executed
};

// Splits `invocations` into a 2-D grid of workgroups (x <= 65535) so big grids need no loop.
// Shaders rebuild the linear index as gl_GlobalInvocationID.x + gl_GlobalInvocationID.y *
// gl_NumWorkGroups.x * workgroupSize.
struct Groups { std::uint32_t x = 1, y = 1; };
Groups groupsFor(std::uint64_t invocations, std::uint32_t workgroupSize);

// The grid kernels' work groups (shaders/grid_dispatch.glsl): 8 x rows, rows = workgroupSize / 8
// (at least 1), their specialization constant 0; gridGroups covers nx x ny x layers invocations.
inline constexpr std::uint32_t kGridGroupWidth = 8;
std::uint32_t gridGroupRows(std::uint32_t workgroupSize);
struct Groups3 { std::uint32_t x = 1, y = 1, z = 1; };
Groups3 gridGroups(std::uint32_t nx, std::uint32_t ny, std::uint32_t layers, std::uint32_t workgroupSize);

}  // namespace blobvk::vk
