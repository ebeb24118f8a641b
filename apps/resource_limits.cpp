#include "resource_limits.h"

#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <stdexcept>
#include <string>

namespace blobvk::app {

std::uint64_t availableMemoryBytes() {
  std::ifstream meminfo("/proc/meminfo");
  std::string key;
  std::uint64_t kib = 0;
  std::string unit;
  while (meminfo >> key >> kib >> unit) {
    if (key == "MemAvailable:") return kib * 1024u;
  }
  const long pages = sysconf(_SC_AVPHYS_PAGES), size = sysconf(_SC_PAGE_SIZE);
  return pages > 0 && size > 0 ? std::uint64_t(pages) * std::uint64_t(size) : 0;
}

std::uint64_t parseByteSize(const std::string& text) {
  std::size_t used = 0;
  double value = 0;
  try {
    value = std::stod(text, &used);
  } catch (const std::exception&) {
    throw std::invalid_argument("'" + text + "' is not a size (examples: 512M, 8G)");
  }
  std::string suffix = text.substr(used);
  std::transform(suffix.begin(), suffix.end(), suffix.begin(), [](unsigned char c) { return char(std::toupper(c)); });
  double scale = 1;
  if (suffix == "" || suffix == "B") scale = 1;
  else if (suffix == "K" || suffix == "KB" || suffix == "KIB") scale = 1024.0;
  else if (suffix == "M" || suffix == "MB" || suffix == "MIB") scale = 1024.0 * 1024.0;
  else if (suffix == "G" || suffix == "GB" || suffix == "GIB") scale = 1024.0 * 1024.0 * 1024.0;
  else throw std::invalid_argument("'" + text + "': unknown unit '" + suffix + "' (use K, M or G)");
  if (!(value > 0) || !std::isfinite(value)) throw std::invalid_argument("'" + text + "' must be positive");
  return std::uint64_t(value * scale);
}

std::uint64_t estimatePolygonizeBytes(const blobtree::GridSpec& grid, const std::string& backend) {
  const double cells = double(grid.cells.x) * grid.cells.y * grid.cells.z;
  // A closed surface crosses O(n^2) of n^3 cells; allow a dense one: 4 * (sum of the face
  // areas in cells) crossing cells, 2 triangles and 1.5 vertices each (a vertex: position,
  // normal, colour, edge key = 44 bytes; a triangle: 12 bytes; plus sorting scratch).
  const double area = 2.0 * (double(grid.cells.x) * grid.cells.y + double(grid.cells.y) * grid.cells.z +
                             double(grid.cells.x) * grid.cells.z);
  const double crossing = std::min(cells, 4.0 * area);
  double bytes = crossing * (2.0 * 12.0 + 1.5 * 44.0) * 2.0;
  // Working sets: the reference keeps three z-layers. The GPU's sparse extraction (bricks of 16^3
  // cells, vk/extract/sparse_polygonizer.h) keeps 8 bytes per brick of the grid and, per active
  // brick, its 17^3 field samples, 6 words per row of points and 1 per row of cells, 27 KB
  // (vk::sparseDeviceBytes);
  // the surface crosses at most as many bricks as the crossing estimate above gives at brick
  // scale, however fine the grid.
  const double layer = double(grid.cells.x + 1) * (grid.cells.y + 1);
  if (backend == "vk") {
    const double bx = std::ceil(grid.cells.x / 16.0), by = std::ceil(grid.cells.y / 16.0), bz = std::ceil(grid.cells.z / 16.0);
    const double active = std::min(bx * by * bz, 8.0 * (bx * by + by * bz + bx * bz));
    bytes += bx * by * bz * 8.0 + active * 27644.0;
  } else {
    bytes += layer * 3.0 * 16.0;
  }
  return std::uint64_t(bytes);
}

std::string formatBytes(std::uint64_t bytes) {
  char buf[64];
  if (bytes >= (1ull << 30)) std::snprintf(buf, sizeof buf, "%.1f GiB", double(bytes) / double(1ull << 30));
  else if (bytes >= (1ull << 20)) std::snprintf(buf, sizeof buf, "%.1f MiB", double(bytes) / double(1ull << 20));
  else if (bytes >= 1024) std::snprintf(buf, sizeof buf, "%.1f KiB", double(bytes) / 1024.0);
  else std::snprintf(buf, sizeof buf, "%llu bytes", static_cast<unsigned long long>(bytes));
  return buf;
}

void checkMemory(std::uint64_t estimate, const Limits& limits, const std::string& what) {
  const bool userLimit = limits.maxMemoryBytes != 0;
  const std::uint64_t limit = userLimit ? limits.maxMemoryBytes : availableMemoryBytes();
  if (limit != 0 && estimate > limit) {
    throw std::runtime_error(what + " may need up to " + formatBytes(estimate) + ", more than " +
                             (userLimit ? "--max-memory (" : "the memory available (") +
                             formatBytes(limit) + "); use a coarser --resolution or --cell-size" +
                             (userLimit ? " or raise --max-memory" : ""));
  }
}

void checkFiniteVertices(std::span<const mesh::Float3> positions, std::uint64_t first) {
  for (std::size_t i = 0; i < positions.size(); ++i) {
    const mesh::Float3& p = positions[i];
    if (std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z)) continue;
    char where[160];
    std::snprintf(where, sizeof where, "vertex %llu is at (%g, %g, %g)", static_cast<unsigned long long>(first + i),
                  double(p.x), double(p.y), double(p.z));
    throw std::runtime_error(std::string(where) +
                             ": the model's field is not finite there (it overflows a 32-bit float); nothing was written");
  }
}

void checkTriangles(std::uint64_t triangles, const Limits& limits) {
  if (limits.maxTriangles != 0 && triangles > limits.maxTriangles) {
    throw std::runtime_error("the mesh has " + std::to_string(triangles) +
                             " triangles, more than --max-triangles " +
                             std::to_string(limits.maxTriangles) + "; nothing was written");
  }
}

}  // namespace blobvk::app
