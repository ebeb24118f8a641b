// The sparse extraction's triangle pass on the host, for CPU devices whose buffers the host maps
// (GpuPolygonizeOptions::hostPassesOnCpuDevices): what brick_triangles.comp does, written straight
// into the mesh's triangle array. On llvmpipe that kernel's loads and stores are loops over the
// lanes (three point words, a neighbour and a case-table row per corner), where a host thread
// reads them from its cache: tower at 512 cells, 1.85 M triangles, about 70 ms of device time
// against a few ms here. The same indices, bit for bit (the kernel's arithmetic on uint32).
#pragma once

#include <array>
#include <cstdint>

namespace blobvk::vk {

// The inputs brick_triangles.comp reads, as the sources pass left them in the batch's buffers.
struct HostTriangleInputs {
  const std::uint32_t* sources = nullptr;     // brick_sources.comp: two words a triangle
  const std::uint32_t* pointWords = nullptr;  // R^3 per batch brick (R = 2^log2B + 1)
  const std::uint32_t* neighbours = nullptr;  // brick_neighbours.comp: 8 words a batch brick
  std::uint32_t log2B = 0;
  std::uint32_t vertexBase = 0;               // vertices of the batches before this one
};

// Writes triangles [0, count) of the batch into `out`, on the worker threads.
void assembleTrianglesOnHost(const HostTriangleInputs& in, std::uint32_t count, std::array<std::uint32_t, 3>* out);

}  // namespace blobvk::vk
