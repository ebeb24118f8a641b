// The sparse extraction's row passes on the host, for CPU devices whose buffers the host maps
// (GpuPolygonizeOptions::hostPassesOnCpuDevices): what brick_rows.comp (each row's vertex and
// triangle counts) and brick_sources.comp (point words, vertex and triangle sources) do, from the
// inside masks the field pass wrote, into the same buffers and the same words. On llvmpipe those
// kernels walk a column of rows per lane with every load and store a loop over the lanes (tower
// at 512 cells: about 30 and 75 ms of device time), where the host walks a brick's rows from its
// cache, brick by brick on the worker threads.
#pragma once

#include <array>
#include <cstdint>

namespace blobvk::vk {

// One batch's layout, as the row kernels' push constants give it (shaders/brick_layout.glsl).
struct HostRowLayout {
  std::array<std::uint32_t, 3> cells{};   // the grid's cells per axis
  std::array<std::uint32_t, 3> bricks{};  // bricks per axis
  std::uint32_t log2B = 0;
  std::uint32_t loaded = 0;     // the batch's bricks: those it emits, then the next layer's
  std::uint32_t ownActive = 0;  // the bricks it emits
  const std::uint32_t* masks = nullptr;     // brick_field.comp: an inside mask per row of points
  const std::uint32_t* segments = nullptr;  // brick_neighbours.comp: four words a brick
};

// brick_rows.comp: each row's vertex count into vertexCounts and, per row of cells, its triangle
// count into triangleCounts, at their segment positions (brick_layout.glsl, segmentOf).
void countRowsOnHost(const HostRowLayout& layout, std::uint32_t* vertexCounts, std::uint32_t* triangleCounts);

// brick_sources.comp, after the scans: the point words of every loaded brick, and where each
// vertex and triangle of the bricks the batch emits comes from (two words each).
void writeSourcesOnHost(const HostRowLayout& layout, const std::uint32_t* vertexSegments,
                        const std::uint32_t* triangleSegments, std::uint32_t* pointWords, std::uint32_t* vertexSources,
                        std::uint32_t* triangleSources);

}  // namespace blobvk::vk
