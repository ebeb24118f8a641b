// The incremental re-mesher behind `blobvk edit`: the CPU's MPU splice
// (cpu_simd/incremental_polygonizer.h) or the Vulkan brick-layer splice
// (vk/extract/incremental_extract.h), with what each update did as a --json row and a text note.
#pragma once

#include "blobvk/blobtree/edit.h"
#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/cpu_simd/mpu_polygonizer.h"
#include "blobvk/mesh/trimesh.h"

#include <nlohmann/json.hpp>

#include <memory>
#include <string>

namespace blobvk::vk {
class Device;
struct GpuPolygonizeOptions;
}  // namespace blobvk::vk

namespace blobvk::app {

struct RemeshReport {
  double ms = 0.0;         // the whole re-mesh
  bool full = false;       // the whole grid was re-meshed
  nlohmann::json fields;   // backend-specific timings and counts for the --json row
  std::string note;        // "12 of 2890 MPUs" / "18 of 4913 bricks"
};

class EditRemesher {
 public:
  virtual ~EditRemesher() = default;
  virtual const mesh::TriMesh& reset(const blobtree::Program& program) = 0;
  virtual const mesh::TriMesh& update(const blobtree::Program& program, const blobtree::Region& region,
                                      RemeshReport& report) = 0;
  // A full polygonization with the same settings (--check compares it with the update's mesh).
  virtual mesh::TriMesh full(const blobtree::Program& program) = 0;
};

std::unique_ptr<EditRemesher> makeCpuRemesher(const blobtree::GridSpec& grid, const cpu::MpuOptions& options);
#ifdef BLOBVK_HAVE_VULKAN
// The device must outlive the remesher.
std::unique_ptr<EditRemesher> makeVkRemesher(vk::Device& device, const blobtree::GridSpec& grid,
                                             const vk::GpuPolygonizeOptions& options);
#endif

}  // namespace blobvk::app
