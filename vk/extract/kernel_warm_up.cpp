#include "blobvk/vk/extract/kernel_warm_up.h"

#include "blobvk/vk/device/shader_layout.h"
#include "blobvk/vk/device/standalone.h"
#include "blobvk/vk/extract/scan.h"

#include <sched.h>

#include <algorithm>
#include <cctype>
#include <condition_variable>
#include <cstdlib>
#include <exception>
#include <mutex>
#include <thread>
#include <utility>

namespace blobvk::vk {

std::vector<KernelRequest> programIndependentSparseKernels(std::uint32_t workgroupSize) {
  // The specialisations of sparse_batches.cpp (SparseBatchRunner::run), then of
  // sparse_polygonizer.cpp (compaction) and scan.cpp: the batches' first, which every job runs,
  // where a job that classifies on the host (host_classify.h) runs none of the others. The
  // warm-up serves CPU devices, where the host runs the row passes (brick_rows, brick_sources,
  // brick_triangles: host_row_passes.h), so they are not listed.
  // tests/vk/test_kernel_warm_up.cpp checks that a sparse job builds each of these, so the list
  // cannot drift from the extraction unnoticed.
  const std::vector<std::uint32_t> wg{workgroupSize}, scan{kScanWorkgroup}, rowStarts{64u};
  return {{"brick_neighbours", wg}, {"scan_reduce", scan}, {"scan_apply", scan}, {"brick_compact", {}},
          {"brick_row_starts", rowStarts}};
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

std::size_t EmptyDispatcher::compile(std::span<const KernelRequest> kernels, const std::atomic<bool>* stop) {
  std::size_t dispatched = 0;
  for (const KernelRequest& request : kernels) {
    if (stop && stop->load()) break;
    dispatch(*device_.kernel(request.shader, request.specs));
    ++dispatched;
  }
  return dispatched;
}

std::size_t compileByEmptyDispatches(Device& device, std::span<const KernelRequest> kernels,
                                     const std::atomic<bool>* stop) {
  return EmptyDispatcher(device).compile(kernels, stop);
}

std::optional<KernelRecipe> takeRecipe(std::vector<KernelRecipe>& recipes, bool dropRecorded) {
  std::erase_if(recipes, [&](const KernelRecipe& r) {
    const KernelPtr k = r.kernel.lock();
    return !k || k->executed.load() || (dropRecorded && k->recorded.load()) || r.buildSeconds > kMaxCopyBuildSeconds;
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
  s.llvmpipe = context.device().info().isLlvmpipe();
  s.mesaCacheDisabled = mesaTrue(std::getenv("MESA_SHADER_CACHE_DISABLE")) || mesaTrue(std::getenv("MESA_GLSL_CACHE_DISABLE"));
  s.pipelineCacheOff = context.pipelineCacheFile().empty();
  s.pipelineCacheLoaded = context.pipelineCacheBytesLoaded() > 0;
  return s;
}

// Shared by the thread, the job device's observer and the owner, so none outlives what it uses.
struct KernelWarmUp::State {
  std::mutex mutex;
  std::condition_variable changed;
  std::vector<KernelRecipe> recipes;
  std::atomic<bool> stop{false};  // set under `mutex` (the waits test it there), read between kernels
  bool idle = false, finished = false;
  Result result;
  std::thread thread;

  void work(const StandaloneOptions& options, std::uint32_t workgroupSize) {
    try {
      StandaloneContext warm(options);
      EmptyDispatcher empty(warm.device());
      result.dispatched = empty.compile(programIndependentSparseKernels(workgroupSize), &stop);
      // What the job's device recorded while this one was busy it compiles itself already.
      bool dropRecorded = true;
      for (;;) {
        std::optional<KernelRecipe> next;
        {
          std::unique_lock lock(mutex);
          for (;;) {
            if (stop) break;
            next = takeRecipe(recipes, std::exchange(dropRecorded, false));
            if (next) break;
            idle = true;
            changed.notify_all();
            changed.wait(lock);
          }
        }
        if (!next) break;
        if (warm.device().findKernel(next->name, next->specs)) continue;  // built (and compiled) here already
        empty.dispatch(*warm.device().kernel(next->name, next->code, next->layoutOf, next->specs));
        ++result.copied;
      }
      result.validationMessages = warm.validationMessages();
    } catch (const std::exception&) {
      result.failed = true;  // an optimisation only: the job builds what it needs itself
    }
    std::lock_guard lock(mutex);
    finished = true;
    recipes.clear();
    changed.notify_all();
  }
};

KernelWarmUp::KernelWarmUp(StandaloneContext& context, const StandaloneOptions& options, std::uint32_t workgroupSize) {
  if (!kernelWarmUpPays(warmUpSigns(context))) return;
  state_ = std::make_shared<State>();
  StandaloneOptions second = options;
  second.pipelineCache = "off";  // the job's context writes the file; this one must not race it
  state_->thread = std::thread([state = state_, second, workgroupSize] { state->work(second, workgroupSize); });
  jobDevice_ = &context.device();
  jobDevice_->setKernelObserver([state = std::weak_ptr<State>(state_)](KernelRecipe recipe) {
    const std::shared_ptr<State> s = state.lock();
    if (!s) return;
    {
      std::lock_guard lock(s->mutex);
      if (s->finished || s->stop) return;
      s->recipes.push_back(std::move(recipe));
      s->idle = false;
    }
    s->changed.notify_all();
  });
}

bool KernelWarmUp::started() const { return state_ != nullptr; }

void KernelWarmUp::stop() {
  if (jobDevice_) jobDevice_->setKernelObserver(nullptr);  // waits for a call in progress
  jobDevice_ = nullptr;
  if (!state_) return;
  {
    std::lock_guard lock(state_->mutex);
    state_->stop = true;
  }
  state_->changed.notify_all();
}

void KernelWarmUp::waitUntilIdle() {
  if (!state_) return;
  std::unique_lock lock(state_->mutex);
  state_->changed.wait(lock, [&] { return state_->idle || state_->finished; });
}

KernelWarmUp::Result KernelWarmUp::wait() {
  stop();
  if (!state_) return {};
  if (state_->thread.joinable()) state_->thread.join();
  return state_->result;
}

KernelWarmUp::~KernelWarmUp() { wait(); }

}  // namespace blobvk::vk
