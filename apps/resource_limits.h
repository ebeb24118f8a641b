// Refuse a job early, with a clear message, when it would need more memory than the machine
// (or the user's --max-memory) allows, instead of swapping or being killed halfway.
#pragma once

#include "blobvk/blobtree/grid.h"
#include "blobvk/mesh/trimesh.h"

#include <cstdint>
#include <span>
#include <string>

namespace blobvk::app {

struct Limits {
  std::uint64_t maxMemoryBytes = 0;  // 0: the memory available now (MemAvailable)
  std::uint64_t maxTriangles = 0;    // 0: unlimited
};

// MemAvailable from /proc/meminfo (physical pages as a fallback).
std::uint64_t availableMemoryBytes();

// Parses "512M", "8G", "1024" (bytes), "2.5G"; throws std::invalid_argument on anything else.
std::uint64_t parseByteSize(const std::string& text);

// Upper bound of the bytes a polygonization of `grid` may need for its output, when the
// surface crosses a generous fraction of the cells, and its own working set.
std::uint64_t estimatePolygonizeBytes(const blobtree::GridSpec& grid, const std::string& backend);

// Throws std::runtime_error naming the estimate and the limit when the job does not fit.
void checkMemory(std::uint64_t estimateBytes, const Limits& limits, const std::string& what);

// Throws when a finished mesh exceeds the triangle limit (the mesh is then not written).
void checkTriangles(std::uint64_t triangles, const Limits& limits);

// Throws, naming the first one, when a vertex position is not finite (a field that overflows a
// float makes NaN vertices): such a mesh is never written. `first` is the index of positions[0].
void checkFiniteVertices(std::span<const mesh::Float3> positions, std::uint64_t first = 0);

std::string formatBytes(std::uint64_t bytes);

}  // namespace blobvk::app
