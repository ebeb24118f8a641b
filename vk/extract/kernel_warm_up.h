// Cold start on lavapipe. llvmpipe generates a kernel's machine code (LLVM's optimisation and code
// generation) at the kernel's first dispatch, on the queue's thread, one kernel after another, and
// keeps it in Mesa's shader cache on disk for later processes. So the first process on a machine
// spends most of its first job compiling on one core while the other waits (tower at 256 cells:
// about 1.7 s of the queue thread's 2.2 s). A warm-up opens a second logical device and, on a
// thread of its own, dispatches the sparse extraction's kernels that do not depend on the program
// (compaction, scans, neighbours, rows, sources, triangles) with no work: their code goes into
// Mesa's cache while the job's device compiles its classification and field kernels, and the
// job's first dispatch of each finds it there. The mesh does not change: the job's device runs
// its own kernels; only where their machine code comes from does.
#pragma once

#include "blobvk/vk/device/context.h"
#include "blobvk/vk/device/standalone.h"

#include <atomic>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <thread>
#include <vector>

namespace blobvk::vk {

struct KernelRequest {
  std::string shader;                // embedded shader name
  std::vector<std::uint32_t> specs;  // its specialisation constants, as the extraction builds it
};

// The sparse extraction's kernels whose code is the same for every program, in the order a job
// first dispatches them, for GpuPolygonizeOptions::workgroupSize `workgroupSize`. (The
// classification, field and vertex kernels carry the program's opcode masks or code.)
std::vector<KernelRequest> programIndependentSparseKernels(std::uint32_t workgroupSize = 64);

// Builds each kernel on `device` and submits one dispatch of it that runs no work group (an
// indirect dispatch whose arguments are zero: llvmpipe generates a kernel's code before it reads
// the group counts), with placeholder buffers. One submit per kernel; `stop` is read between
// them. Returns how many kernels were dispatched.
std::size_t compileByEmptyDispatches(Device& device, std::span<const KernelRequest> kernels,
                                     const std::atomic<bool>* stop = nullptr);

// Whether a warm-up can pay: the device is llvmpipe (other drivers compile at pipeline creation,
// on the caller's threads), Mesa's shader cache is on (MESA_SHADER_CACHE_DISABLE unset or false:
// the cache is how the code reaches the job's device), and blobvk's pipeline cache file is in use
// but was not there (a first process with this driver and blobvk version: Mesa's cache is
// probably as empty; with the file off nothing tells, and a warm process gains nothing).
struct WarmUpSigns {
  bool llvmpipe = false;
  bool mesaCacheDisabled = false;
  bool pipelineCacheOff = false;
  bool pipelineCacheLoaded = false;
};
bool kernelWarmUpPays(const WarmUpSigns& signs);
WarmUpSigns warmUpSigns(StandaloneContext& context);  // reads MESA_SHADER_CACHE_DISABLE too

// The warm-up of a context's device, when kernelWarmUpPays: a second StandaloneContext on the same
// device (the context's options, without a pipeline cache file) on a thread that runs
// compileByEmptyDispatches. Errors there only end the warm-up (the job builds its kernels itself).
// The destructor stops it between kernels and joins the thread.
class KernelWarmUp {
 public:
  KernelWarmUp(StandaloneContext& context, const StandaloneOptions& options,
               std::uint32_t workgroupSize = 64);
  ~KernelWarmUp();
  KernelWarmUp(const KernelWarmUp&) = delete;
  KernelWarmUp& operator=(const KernelWarmUp&) = delete;

  bool started() const { return thread_.joinable(); }
  // Waits for the warm-up to end (at once when it did not start).
  struct Result {
    std::size_t dispatched = 0;            // kernels compiled
    std::uint32_t validationMessages = 0;  // of its context, with StandaloneOptions::validation
    bool failed = false;                   // an error ended it
  };
  Result wait();

 private:
  std::atomic<bool> stop_{false};
  Result result_;
  std::thread thread_;
};

}  // namespace blobvk::vk
