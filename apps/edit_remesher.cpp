#include "edit_remesher.h"

#include "blobvk/cpu_simd/incremental_polygonizer.h"

#ifdef BLOBVK_HAVE_VULKAN
#include "blobvk/vk/extract/incremental_extract.h"
#include "blobvk/vk/extract/polygonize.h"
#endif

#include <string>

namespace blobvk::app {
namespace {

class CpuRemesher final : public EditRemesher {
 public:
  CpuRemesher(const blobtree::GridSpec& grid, const cpu::MpuOptions& options)
      : grid_(grid), options_(options), inc_(grid, options) {}
  const mesh::TriMesh& reset(const blobtree::Program& program) override { return inc_.reset(program); }
  const mesh::TriMesh& update(const blobtree::Program& program, const blobtree::Region& region,
                              RemeshReport& report) override {
    cpu::IncrementalStats st;
    const mesh::TriMesh& m = inc_.update(program, region, &st);
    report.ms = st.msTotal;
    report.full = st.full;
    report.fields = {{"polygonize_ms", st.msPolygonize}, {"splice_ms", st.msSplice}, {"mpus_rerun", st.mpusRerun},
                     {"mpus", st.mpus}};
    report.note = std::to_string(st.mpusRerun) + " of " + std::to_string(st.mpus) + " MPUs";
    return m;
  }
  mesh::TriMesh full(const blobtree::Program& program) override { return cpu::polygonizeMpu(program, grid_, options_); }

 private:
  blobtree::GridSpec grid_;
  cpu::MpuOptions options_;
  cpu::IncrementalPolygonizer inc_;
};

#ifdef BLOBVK_HAVE_VULKAN
class VkRemesher final : public EditRemesher {
 public:
  VkRemesher(vk::Device& device, const blobtree::GridSpec& grid, const vk::GpuPolygonizeOptions& options)
      : device_(device), grid_(grid), inc_(device, grid, options) {}
  const mesh::TriMesh& reset(const blobtree::Program& program) override { return inc_.reset(program); }
  const mesh::TriMesh& update(const blobtree::Program& program, const blobtree::Region& region,
                              RemeshReport& report) override {
    vk::IncrementalGpuStats st;
    const mesh::TriMesh& m = inc_.update(program, region, &st);
    report.ms = st.msTotal;
    report.full = st.full;
    report.fields = {{"classify_ms", st.msClassify},      {"extract_ms", st.msExtract},
                     {"splice_ms", st.msSplice},          {"layers_rerun", st.layersRerun},
                     {"first_layer", st.firstLayer},      {"layers", st.layers},
                     {"bricks_rerun", st.bricksRerun},    {"bricks", st.bricks},
                     {"active_bricks_rerun", st.gpu.activeBricks}, {"submits", st.gpu.submits},
                     {"evaluator", st.bricksRerun ? vk::traversalName(st.gpu.traversal) : "none"}};
    report.note = std::to_string(st.bricksRerun) + " of " + std::to_string(st.bricks) + " bricks";
    return m;
  }
  // The session's options (the evaluator resolved once), so the bytes must agree.
  mesh::TriMesh full(const blobtree::Program& program) override {
    return vk::polygonize(device_, program, grid_, inc_.options());
  }

 private:
  vk::Device& device_;
  blobtree::GridSpec grid_;
  vk::IncrementalExtractor inc_;
};
#endif

}  // namespace

std::unique_ptr<EditRemesher> makeCpuRemesher(const blobtree::GridSpec& grid, const cpu::MpuOptions& options) {
  return std::make_unique<CpuRemesher>(grid, options);
}

#ifdef BLOBVK_HAVE_VULKAN
std::unique_ptr<EditRemesher> makeVkRemesher(vk::Device& device, const blobtree::GridSpec& grid,
                                             const vk::GpuPolygonizeOptions& options) {
  return std::make_unique<VkRemesher>(device, grid, options);
}
#endif

}  // namespace blobvk::app
