// How the library meets a Vulkan device: a HostContext holds the engine's handles (never
// destroyed by us); a Device wraps one with our private dispatch table, memory allocator,
// pipeline cache and a one-shot submit path. StandaloneContext (standalone.h) creates its own.
#pragma once

#include "vk/dispatch.h"
#include "vk/memory.h"

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <span>
#include <string>
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
  explicit operator bool() const { return buffer_ != VK_NULL_HANDLE; }

 private:
  friend class Device;
  class Device* device_ = nullptr;
  VkBuffer buffer_ = VK_NULL_HANDLE;
  VkDeviceSize size_ = 0;
  Allocation allocation_{};
};

// A compute pipeline over `bindings` storage buffers (set 0, bindings 0..n-1) and up to 128
// bytes of push constants.
struct Kernel {
  VkDescriptorSetLayout setLayout = VK_NULL_HANDLE;
  VkPipelineLayout layout = VK_NULL_HANDLE;
  VkPipeline pipeline = VK_NULL_HANDLE;
  std::uint32_t bindings = 0;
  std::uint32_t workgroupSize = 0;
};

struct DeviceInfo {
  std::string name;
  VkPhysicalDeviceType type = VK_PHYSICAL_DEVICE_TYPE_OTHER;
  std::uint32_t apiVersion = 0;
  std::uint32_t subgroupSize = 0;
  VkPhysicalDeviceLimits limits{};
};

class Device {
 public:
  explicit Device(const HostContext& host);
  ~Device();
  Device(const Device&) = delete;
  Device& operator=(const Device&) = delete;

  const Dispatch& d() const { return d_; }
  VkDevice handle() const { return host_.device; }
  const HostContext& host() const { return host_; }
  const DeviceInfo& info() const { return info_; }
  MemoryAllocator& memory() { return *memory_; }

  // Storage buffer (also transfer src/dst and indirect). `use` picks the memory.
  Buffer createBuffer(VkDeviceSize size, MemoryUse use = MemoryUse::DeviceLocal,
                      VkBufferUsageFlags extraUsage = 0);
  // Copies host data into / out of a buffer: a memcpy when it is mapped, else through a staging
  // buffer and a one-shot submit. forceStaging() exercises the discrete-GPU path on lavapipe.
  void upload(Buffer& dst, const void* data, VkDeviceSize bytes, VkDeviceSize offset = 0);
  void download(const Buffer& src, void* data, VkDeviceSize bytes, VkDeviceSize offset = 0);
  void setForceStaging(bool on) { forceStaging_ = on; }
  bool forceStaging() const { return forceStaging_; }

  // Cached compute pipeline for an embedded shader with specialization constants
  // (constant_id i = specs[i]; constant 0 is the workgroup size by convention).
  const Kernel& kernel(const std::string& shader, std::uint32_t bindings,
                       std::span<const std::uint32_t> specs);
  // The same for SPIR-V made at run time (vk/runtime_compiler.h); `name` must identify the code
  // (e.g. shader + a hash of the source), since pipelines are cached by name and specs.
  const Kernel& kernel(const std::string& name, std::span<const std::uint32_t> code,
                       std::uint32_t bindings, std::span<const std::uint32_t> specs);
  // A cached pipeline, or null (lets callers skip generating code that is already built).
  const Kernel* findKernel(const std::string& name, std::span<const std::uint32_t> specs) const;

  // Records with `record`, submits to the host queue and waits. Throws on device loss.
  void submitAndWait(const std::function<void(VkCommandBuffer)>& record);
  // The same with a Recorder that stays alive (with its descriptor sets) until the fence.
  void run(const std::function<void(class Recorder&)>& record);

  // Nanoseconds per timestamp tick; 0 when the queue has no timestamps.
  double timestampPeriodNs() const { return timestampPeriod_; }

 private:
  friend class Buffer;
  void destroyBuffer(Buffer& b);
  const Kernel& createKernel(const std::string& key, const std::string& shader,
                             std::span<const std::uint32_t> code, std::uint32_t bindings,
                             std::span<const std::uint32_t> specs);

  HostContext host_;
  Dispatch d_;
  DeviceInfo info_;
  std::unique_ptr<MemoryAllocator> memory_;
  VkPipelineCache pipelineCache_ = VK_NULL_HANDLE;
  VkCommandPool commandPool_ = VK_NULL_HANDLE;
  VkFence fence_ = VK_NULL_HANDLE;
  bool forceStaging_ = false;
  double timestampPeriod_ = 0.0;
  std::map<std::string, Kernel> kernels_;
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
  void fill(const Buffer& b, std::uint32_t value);

 private:
  VkDescriptorSet allocateSet(VkDescriptorSetLayout layout);
  void bind(const Kernel& kernel, std::span<const BufferRange> buffers, const void* push, std::uint32_t pushSize);
  Device& device_;
  VkCommandBuffer cmd_;
  std::vector<VkDescriptorPool> pools_;
  std::uint32_t setsLeft_ = 0;
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
