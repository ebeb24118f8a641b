// Several kernels built at once. A job's kernels are independent (each its own SPIR-V, layout
// and pipeline), and on lavapipe vkCreateComputePipelines is single-threaded NIR work on the
// calling thread, so a job that needs eight field tile kernels creates them fastest on every
// core rather than one after the other.
#pragma once

#include "blobvk/vk/device/context.h"

#include <cstdint>
#include <functional>
#include <span>
#include <vector>

namespace blobvk::vk {

// Runs every build, the calling thread and up to `threads` - 1 helpers taking the next one not
// started (threads 0: std::thread::hardware_concurrency()), and returns the kernels in the
// builds' order whatever thread made them. A build that throws does not stop the others; once
// all have ended, the exception of the first failed build (in the builds' order) is rethrown.
// The builds must be safe to run at once: Device::kernel is (vk/device/context.h).
std::vector<KernelPtr> buildConcurrently(std::span<const std::function<KernelPtr()>> builds, std::uint32_t threads = 0);

// Builds this process has run on a helper thread of buildConcurrently (tests: proof that the
// work was shared, without timing it).
std::uint64_t concurrentBuildsOnHelpers();

}  // namespace blobvk::vk
