#include "backends.h"

#include "cpu_simd/mpu_polygonizer.h"
#include "cpu_simd/reference_polygonizer.h"

#ifdef BLOBVK_HAVE_VULKAN
#include "vk/polygonize.h"
#include "vk/standalone.h"
#endif

#include <chrono>
#include <stdexcept>

namespace blobvk::app {

std::vector<std::string> backendNames() {
  std::vector<std::string> names{"cpu", "reference"};
#ifdef BLOBVK_HAVE_VULKAN
  names.push_back("vk");
#endif
  return names;
}

mesh::TriMesh polygonize(const blobtree::Program& program, const blobtree::GridSpec& grid,
                         const PolygonizeSettings& settings, PolygonizeStats* stats) {
  const auto start = std::chrono::steady_clock::now();
  mesh::TriMesh mesh;
  double evaluations = 0.0;
  if (settings.backend == "cpu") {
    cpu::MpuOptions options;
    options.threads = settings.threads;
    options.refineSteps = settings.refineSteps;
    if (settings.mpuSize > 0) options.mpuCells = settings.mpuSize;
    cpu::MpuStats mpu;
    mesh = cpu::polygonizeMpu(program, grid, options, &mpu);
    evaluations = double(mpu.pointEvaluations);
  } else if (settings.backend == "reference") {
    cpu::ReferenceOptions options;
    options.refineSteps = settings.refineSteps;
    mesh = cpu::polygonizeReference(program, grid, options);
    evaluations = double(grid.pointCount());
#ifdef BLOBVK_HAVE_VULKAN
  } else if (settings.backend == "vk") {
    vk::StandaloneOptions deviceOptions;
    deviceOptions.device = settings.device;
    deviceOptions.validation = settings.validation;
    vk::StandaloneContext context(deviceOptions);
    vk::GpuPolygonizeOptions options;
    options.refineSteps = settings.refineSteps;
    options.traversal = settings.stackBased ? vk::Traversal::StackBased : vk::Traversal::Stackless;
    vk::GpuStats gpu;
    mesh = vk::polygonize(context.device(), program, grid, options, &gpu);
    evaluations = double(gpu.fieldEvaluations);
    if (context.validationMessages() != 0) {
      throw std::runtime_error("the Vulkan validation layer reported " +
                               std::to_string(context.validationMessages()) + " message(s)");
    }
#endif
  } else {
    std::string known;
    for (const std::string& n : backendNames()) known += (known.empty() ? "" : ", ") + n;
    throw std::invalid_argument("unknown backend '" + settings.backend + "' (known: " + known + ")");
  }
  if (stats) {
    stats->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    stats->pointEvaluations = evaluations;
  }
  return mesh;
}

}  // namespace blobvk::app
