#include "blobvk/vk/device/concurrent_builds.h"

#include <algorithm>
#include <atomic>
#include <exception>
#include <system_error>
#include <thread>

namespace blobvk::vk {
namespace {
std::atomic<std::uint64_t> helperBuilds{0};
}  // namespace

std::uint64_t concurrentBuildsOnHelpers() { return helperBuilds.load(); }

std::vector<KernelPtr> buildConcurrently(std::span<const std::function<KernelPtr()>> builds, std::uint32_t threads) {
  const std::size_t n = builds.size();
  std::vector<KernelPtr> kernels(n);
  std::vector<std::exception_ptr> errors(n);
  if (threads == 0) threads = std::max(1u, std::thread::hardware_concurrency());
  // What the threads share: `next` (atomic), and the slots of `kernels` and `errors`, each
  // written by the one thread that took its index and read only after every helper is joined.
  std::atomic<std::size_t> next{0};
  auto work = [&](bool helper) {
    for (std::size_t i; (i = next.fetch_add(1)) < n;) {
      try {
        kernels[i] = builds[i]();
      } catch (...) {
        errors[i] = std::current_exception();
      }
      if (helper) ++helperBuilds;
    }
  };
  std::vector<std::thread> helpers;
  const std::size_t helperCount = std::min<std::size_t>(threads, n) - (n > 0 ? 1 : 0);
  for (std::size_t h = 0; h < helperCount; ++h) {
    try {
      helpers.emplace_back(work, true);
    } catch (const std::system_error&) {  // no thread to be had: the ones running share the rest
      break;
    }
  }
  work(false);
  for (std::thread& t : helpers) t.join();
  for (const std::exception_ptr& e : errors)
    if (e) std::rethrow_exception(e);
  return kernels;
}

}  // namespace blobvk::vk
