// Cold start on lavapipe. llvmpipe generates a kernel's machine code (LLVM's optimisation and code
// generation) at the kernel's first dispatch, on the queue's thread, one kernel after another, and
// keeps it in Mesa's shader cache on disk for later processes. So the first process on a machine
// spends most of its first job compiling on one core while the other waits (tower at 256 cells:
// about 1.7 s of the queue thread's 2.2 s). A warm-up opens a second logical device and, on a
// thread of its own, compiles there what the job's device will need next, dispatching each
// kernel with no work: its code goes into Mesa's cache, where the job's first dispatch of it finds
// it. First the sparse extraction's kernels that do not depend on the program (compaction, scans,
// neighbours, rows, sources, triangles), while the job's device compiles its classification; then
// the kernels the job's device builds (field tiles, vertex kernel), newest first, while the job's
// device compiles them oldest first. The mesh does not change: the job's device runs its own
// kernels; only where their machine code comes from does.
#pragma once

#include "blobvk/vk/device/context.h"

#include <atomic>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace blobvk::vk {

class StandaloneContext;
struct StandaloneOptions;

struct KernelRequest {
  std::string shader;                // embedded shader name
  std::vector<std::uint32_t> specs;  // its specialisation constants, as the extraction builds it
};

// The sparse extraction's kernels whose code is the same for every program, in the order a job
// first dispatches them, for GpuPolygonizeOptions::workgroupSize `workgroupSize`. (The
// classification, field and vertex kernels carry the program's opcode masks or code.)
std::vector<KernelRequest> programIndependentSparseKernels(std::uint32_t workgroupSize = 64);

// Dispatches kernels with no work group (an indirect dispatch whose arguments are zero: llvmpipe
// generates a kernel's code before it reads the group counts), with placeholder buffers, one
// submit each.
class EmptyDispatcher {
 public:
  explicit EmptyDispatcher(Device& device);
  void dispatch(const Kernel& kernel);
  // Builds each kernel on the device and dispatches it; `stop` is read between kernels. Returns
  // how many kernels were dispatched.
  std::size_t compile(std::span<const KernelRequest> kernels, const std::atomic<bool>* stop = nullptr);

 private:
  Device& device_;
  Buffer storage_, uniform_, args_;
};

// EmptyDispatcher(device).compile(kernels, stop).
std::size_t compileByEmptyDispatches(Device& device, std::span<const KernelRequest> kernels,
                                     const std::atomic<bool>* stop = nullptr);

// The next of the job's kernels to compile on the warm-up's device: `recipes` (in the order the
// job's device built them) lose what needs no copy (the kernel is gone, or has run on the job's
// device, or, with `dropRecorded`, is already recorded there: the job's device is compiling it or
// is about to) or cannot pay (its pipeline took the job's device more than kMaxCopyBuildSeconds
// to build: the copy's own build would end after the job's device has compiled it, and only take
// a core from the job; random128's generated vertex kernel, 0.7-1.4 s), and the newest of the
// rest is taken out (the job's device compiles from the oldest, so the two meet in the middle).
// Empty when none is left.
inline constexpr double kMaxCopyBuildSeconds = 0.25;  // field tiles: 0.01-0.04 s each
std::optional<KernelRecipe> takeRecipe(std::vector<KernelRecipe>& recipes, bool dropRecorded);

// Whether a warm-up can pay: the device is llvmpipe (other drivers compile at pipeline creation,
// on the caller's threads); Mesa's shader cache is on (MESA_SHADER_CACHE_DISABLE and the older
// MESA_GLSL_CACHE_DISABLE unset or false: the cache is how the code reaches the job's device);
// blobvk's pipeline cache file is in use but was not there (a first process with this driver and
// blobvk version: Mesa's cache is probably as empty; with the file off nothing tells, and a warm
// process gains nothing); and the process may run on a second core (on one, it would only take
// time from the job).
struct WarmUpSigns {
  unsigned cores = 0;  // the cores the process may run on
  bool llvmpipe = false;
  bool mesaCacheDisabled = false;
  bool pipelineCacheOff = false;
  bool pipelineCacheLoaded = false;
};
bool kernelWarmUpPays(const WarmUpSigns& signs);
// The signs of `context` (and of the environment's Mesa variables).
WarmUpSigns warmUpSigns(StandaloneContext& context);

// The warm-up of a context's device, when kernelWarmUpPays: a second StandaloneContext on the same
// device (the context's options, without a pipeline cache file) on a thread that compiles the
// program-independent kernels, then copies of the kernels the context's device builds (its kernel
// observer) until stop(). Errors there only end the warm-up (the job builds its kernels itself).
// It must end (destruction) before `context` does: a copy may hold one of its kernels.
class KernelWarmUp {
 public:
  KernelWarmUp(StandaloneContext& context, const StandaloneOptions& options, std::uint32_t workgroupSize = 64);
  ~KernelWarmUp();  // stop(), then joins the thread
  KernelWarmUp(const KernelWarmUp&) = delete;
  KernelWarmUp& operator=(const KernelWarmUp&) = delete;

  bool started() const;
  // No more copies (the first job is done: later ones find their kernels built); the kernel in
  // progress finishes. Does not wait.
  void stop();
  // Waits until the program-independent kernels are done and no copy is pending, or the warm-up
  // has ended (tests).
  void waitUntilIdle();
  struct Result {
    std::size_t dispatched = 0;            // program-independent kernels compiled
    std::size_t copied = 0;                // kernels of the job's device compiled (not already there)
    std::uint32_t validationMessages = 0;  // of its context (StandaloneOptions::validation, tests)
    bool failed = false;                   // an error ended it
  };
  // stop(), then waits for the thread.
  Result wait();

 private:
  struct State;  // the thread, its queue and its flags (kernel_warm_up.cpp)
  Device* jobDevice_ = nullptr;
  std::shared_ptr<State> state_;
};

}  // namespace blobvk::vk
