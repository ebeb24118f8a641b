#include "blobvk/vk/extract/kernel_warm_up.h"

#include "blobvk/vk/device/shader_layout.h"
#include "blobvk/vk/extract/scan.h"

#include <sched.h>

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <exception>
#include <utility>

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

// No work group runs, so nothing reads or writes the placeholders; 64 KiB covers any uniform
// block's declared size. The arguments buffer holds the zero group counts.
EmptyDispatcher::EmptyDispatcher(Device& device)
    : device_(device),
      storage_(device.createBuffer(64u << 10)),
      uniform_(device.createBuffer(64u << 10, MemoryUse::DeviceLocal, VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT)),
      args_(device.createBuffer(16, MemoryUse::DeviceLocal, VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT)) {
  const std::uint32_t zeros[4] = {0, 0, 0, 0};
  device.upload(args_, zeros, sizeof(zeros));
}

void EmptyDispatcher::dispatch(const Kernel& kernel) {
  std::vector<BufferRange> bind;
  for (std::uint32_t i = 0; i < kernel.bindings; ++i)
    bind.push_back(kernel.shaderLayout->bindings[i].type == VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER ? BufferRange(uniform_)
                                                                                             : BufferRange(storage_));
  const std::uint8_t push[128] = {};
  device_.run([&](Recorder& rec) { rec.dispatchIndirect(kernel, bind, push, kernel.pushConstantRange, args_, 0); });
}

std::size_t compileByEmptyDispatches(Device& device, std::span<const KernelRequest> kernels,
                                     const std::atomic<bool>* stop) {
  EmptyDispatcher empty(device);
  std::size_t dispatched = 0;
  for (const KernelRequest& request : kernels) {
    if (stop && stop->load()) break;
    empty.dispatch(*device.kernel(request.shader, request.specs));
    ++dispatched;
  }
  return dispatched;
}

std::optional<KernelRecipe> takeRecipe(std::vector<KernelRecipe>& recipes, bool dropRecorded) {
  std::erase_if(recipes, [&](const KernelRecipe& r) {
    const KernelPtr k = r.kernel.lock();
    return !k || k->executed.load() || (dropRecorded && k->recorded.load());
  });
  if (recipes.empty()) return std::nullopt;
  KernelRecipe newest = std::move(recipes.back());
  recipes.pop_back();
  return newest;
}

bool kernelWarmUpPays(const WarmUpSigns& signs) {
  return signs.cores >= 2 && signs.llvmpipe && !signs.mesaCacheDisabled && !signs.pipelineCacheOff && !signs.pipelineCacheLoaded;
}

namespace {
// Mesa reads its boolean variables as "1", "true", "y" or "yes" (any case) for true.
bool mesaTrue(const char* value) {
  if (!value) return false;
  std::string v(value);
  std::transform(v.begin(), v.end(), v.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return v == "1" || v == "true" || v == "y" || v == "yes";
}
// The cores this process may run on (taskset and cpusets included), else the machine's.
unsigned usableCores() {
  cpu_set_t set;
  if (sched_getaffinity(0, sizeof set, &set) == 0) return unsigned(CPU_COUNT(&set));
  return std::thread::hardware_concurrency();
}
}  // namespace

WarmUpSigns warmUpSigns(StandaloneContext& context) {
  WarmUpSigns s;
  s.cores = usableCores();
  s.llvmpipe = context.device().info().name.rfind("llvmpipe", 0) == 0;
  s.mesaCacheDisabled = mesaTrue(std::getenv("MESA_SHADER_CACHE_DISABLE"));
  s.pipelineCacheOff = context.pipelineCacheFile().empty();
  s.pipelineCacheLoaded = context.pipelineCacheBytesLoaded() > 0;
  return s;
}

KernelWarmUp::KernelWarmUp(StandaloneContext& context, const StandaloneOptions& options, std::uint32_t workgroupSize) {
  if (!kernelWarmUpPays(warmUpSigns(context))) return;
  jobDevice_ = &context.device();
  jobDevice_->setKernelObserver([this](KernelRecipe recipe) {
    {
      std::lock_guard lock(mutex_);
      recipes_.push_back(std::move(recipe));
      idle_ = false;
    }
    changed_.notify_all();
  });
  StandaloneOptions second = options;
  second.pipelineCache = "off";  // the job's context writes the file; this one must not race it
  thread_ = std::thread([this, second, workgroupSize] { work(second, workgroupSize); });
}

void KernelWarmUp::work(StandaloneOptions options, std::uint32_t workgroupSize) {
  try {
    StandaloneContext warm(options);
    const std::vector<KernelRequest> fixed = programIndependentSparseKernels(workgroupSize);
    result_.dispatched = compileByEmptyDispatches(warm.device(), fixed, &stopFlag_);
    EmptyDispatcher empty(warm.device());
    // What the job's device recorded while this one was busy it compiles itself already.
    bool dropRecorded = true;
    for (;;) {
      std::optional<KernelRecipe> next;
      {
        std::unique_lock lock(mutex_);
        for (;;) {
          if (stop_) break;
          next = takeRecipe(recipes_, std::exchange(dropRecorded, false));
          if (next) break;
          idle_ = true;
          changed_.notify_all();
          changed_.wait(lock);
        }
      }
      if (!next) break;
      empty.dispatch(*warm.device().kernel(next->name, next->code, next->layoutOf, next->specs));
      ++result_.copied;
    }
    result_.validationMessages = warm.validationMessages();
  } catch (const std::exception&) {
    result_.failed = true;  // an optimisation only: the job builds what it needs itself
  }
  std::lock_guard lock(mutex_);
  idle_ = true;
  changed_.notify_all();
}

void KernelWarmUp::stop() {
  if (jobDevice_) jobDevice_->setKernelObserver(nullptr);  // waits for a call in progress
  jobDevice_ = nullptr;
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  stopFlag_ = true;
  changed_.notify_all();
}

void KernelWarmUp::waitUntilIdle() {
  if (!thread_.joinable()) return;
  std::unique_lock lock(mutex_);
  changed_.wait(lock, [&] { return idle_; });
}

KernelWarmUp::Result KernelWarmUp::wait() {
  stop();
  if (thread_.joinable()) thread_.join();
  return result_;
}

KernelWarmUp::~KernelWarmUp() { wait(); }

}  // namespace blobvk::vk
