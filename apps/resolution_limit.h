// One limit for every --resolution that holds a mesh (render, bench, compare, simulate, cut;
// mesh streams what does not fit and has the streamed limit of mesh_streaming.h) and one for
// every image side, so the same number is accepted or refused by all commands.
#pragma once

#include <CLI/CLI.hpp>

namespace blobvk::app {

// The finest grid any command accepts: the largest N for which the polygonization estimate of
// an N x N x N grid (resource_limits.h, the smallest backend working set) fits in the machine's
// physical memory. Jobs below it are still checked against the memory available at run time.
int maxResolution();

// CLI11 check: 1 <= value <= maxResolution(), naming the limit and why it is what it is.
CLI::Validator resolutionRange(int minimum = 1);

// Images (render --size, --image-size of compare, simulate and cut): Vulkan's common
// maxImageDimension2D, which lavapipe and desktop GPUs all reach.
inline constexpr int kMaxImageSide = 16384;

}  // namespace blobvk::app
