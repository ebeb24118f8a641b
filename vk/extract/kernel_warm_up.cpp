#include "blobvk/vk/extract/kernel_warm_up.h"

#include "blobvk/vk/device/shader_layout.h"
#include "blobvk/vk/extract/scan.h"

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <cstring>
#include <exception>

namespace blobvk::vk {

std::vector<KernelRequest> programIndependentSparseKernels(std::uint32_t workgroupSize) {
  // The specialisations of vk/extract/sparse_polygonizer.cpp (compaction), scan.cpp and
  // sparse_batches.cpp (SparseBatchRunner::run); tests/vk/test_kernel_warm_up.cpp checks that a
  // sparse job builds each of these, so the list cannot drift from the extraction unnoticed.
  const std::vector<std::uint32_t> wg{workgroupSize}, scan{kScanWorkgroup}, rowStarts{64u};
  return {{"scan_reduce", scan},           {"scan_apply", scan},       {"brick_compact", {}},
          {"brick_row_starts", rowStarts}, {"brick_neighbours", wg},   {"brick_rows", wg},
          {"brick_sources", wg},           {"brick_triangles", wg}};
}

std::size_t compileByEmptyDispatches(Device& device, std::span<const KernelRequest> kernels,
                                     const std::atomic<bool>* stop) {
  // Placeholder buffers: no work group runs, so nothing reads or writes them; 64 KiB covers any
  // uniform block's declared size. The arguments buffer holds the zero group counts.
  Buffer storage = device.createBuffer(64u << 10);
  Buffer uniform = device.createBuffer(64u << 10, MemoryUse::DeviceLocal, VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT);
  Buffer args = device.createBuffer(16, MemoryUse::DeviceLocal, VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT);
  const std::uint32_t zeros[4] = {0, 0, 0, 0};
  device.upload(args, zeros, sizeof(zeros));
  const std::uint8_t push[128] = {};
  std::size_t dispatched = 0;
  for (const KernelRequest& request : kernels) {
    if (stop && stop->load()) break;
    const KernelPtr kernel = device.kernel(request.shader, request.specs);
    std::vector<BufferRange> bind;
    for (std::uint32_t i = 0; i < kernel->bindings; ++i)
      bind.push_back(kernel->shaderLayout->bindings[i].type == VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER ? BufferRange(uniform)
                                                                                                : BufferRange(storage));
    device.run([&](Recorder& rec) {
      rec.dispatchIndirect(*kernel, bind, push, kernel->pushConstantRange, args, 0);
    });
    ++dispatched;
  }
  return dispatched;
}

bool kernelWarmUpPays(const WarmUpSigns& signs) {
  return signs.llvmpipe && !signs.mesaCacheDisabled && !signs.pipelineCacheOff && !signs.pipelineCacheLoaded;
}

namespace {
// Mesa reads its boolean variables as "1", "true", "y" or "yes" (any case) for true.
bool mesaTrue(const char* value) {
  if (!value) return false;
  std::string v(value);
  std::transform(v.begin(), v.end(), v.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return v == "1" || v == "true" || v == "y" || v == "yes";
}
}  // namespace

WarmUpSigns warmUpSigns(StandaloneContext& context) {
  WarmUpSigns s;
  s.llvmpipe = context.device().info().name.rfind("llvmpipe", 0) == 0;
  s.mesaCacheDisabled = mesaTrue(std::getenv("MESA_SHADER_CACHE_DISABLE"));
  s.pipelineCacheOff = context.pipelineCacheFile().empty();
  s.pipelineCacheLoaded = context.pipelineCacheBytesLoaded() > 0;
  return s;
}

KernelWarmUp::KernelWarmUp(StandaloneContext& context, const StandaloneOptions& options,
                           std::uint32_t workgroupSize) {
  if (!kernelWarmUpPays(warmUpSigns(context))) return;
  StandaloneOptions second = options;
  second.pipelineCache = "off";  // the job's context writes the file; this one must not race it
  thread_ = std::thread([this, second, workgroupSize] {
    try {
      StandaloneContext warm(second);
      const std::vector<KernelRequest> kernels = programIndependentSparseKernels(workgroupSize);
      result_.dispatched = compileByEmptyDispatches(warm.device(), kernels, &stop_);
      result_.validationMessages = warm.validationMessages();
    } catch (const std::exception&) {
      result_.failed = true;  // an optimisation only: the job builds what it needs itself
    }
  });
}

KernelWarmUp::Result KernelWarmUp::wait() {
  if (thread_.joinable()) thread_.join();
  return result_;
}

KernelWarmUp::~KernelWarmUp() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
}

}  // namespace blobvk::vk
