// Two ways of running the sparse path that must give the same mesh (the host's pass or the
// device's, uniform blocks or storage buffers...): every shipped scene, in one batch and in
// batches of 5 bricks (whose next-layer offsets come from the scanned counts), meshed with the
// base options and again with one option changed, compared byte for byte and with the CPU
// reference. The caller's check asserts what each run reports it did.
#pragma once

#include "blobvk/cpu_simd/reference_polygonizer.h"
#include "blobvk/vk/extract/polygonize.h"
#include "reference_checks.h"
#include "shipped_scenes.h"

#include <cstdint>
#include <functional>
#include <string>

namespace blobvk::testing {

struct BothPaths {
  int resolution = 48;
  // The scenes to run (empty: all of them).
  std::function<bool(const ShippedScene&)> keep;
  // The first run's options for a scene (maxBatchBricks is set per run).
  std::function<vk::GpuPolygonizeOptions(const ShippedScene&)> base;
  // What the second run changes.
  std::function<void(vk::GpuPolygonizeOptions&)> change;
  // `what` names the scene and batching; `first` and `second` are the runs' stats.
  std::function<void(const std::string& what, const ShippedScene&, const mesh::TriMesh& reference,
                     const vk::GpuStats& first, const vk::GpuStats& second)>
      check;
};

inline void expectBothPathsGiveTheSameMeshes(vk::Device& device, const BothPaths& paths) {
  for (const std::string& name : shippedSceneNames()) {
    const ShippedScene s = shipped(name, paths.resolution);
    if (paths.keep && !paths.keep(s)) continue;
    const mesh::TriMesh reference = cpu::polygonizeReference(s.program, s.grid, {});
    for (const std::uint32_t batchBricks : {0u, 5u}) {
      const std::string what = name + ", batches of " + std::to_string(batchBricks);
      vk::GpuPolygonizeOptions o = paths.base(s);
      o.maxBatchBricks = batchBricks;
      vk::GpuStats first, second;
      const mesh::TriMesh a = vk::polygonize(device, s.program, s.grid, o, &first);
      paths.change(o);
      const mesh::TriMesh b = vk::polygonize(device, s.program, s.grid, o, &second);
      expectSameBytes(a, b, what);
      const bool cpuDevice = device.info().type == VK_PHYSICAL_DEVICE_TYPE_CPU;
      expectSameMeshAsReference(a, reference, referenceToleranceCells(cpuDevice) * s.grid.cellSize, what);
      paths.check(what, s, reference, first, second);
    }
  }
}

}  // namespace blobvk::testing
