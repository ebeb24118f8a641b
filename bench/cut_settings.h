// The simulation of the FEM cut benchmarks (bench_fem's topology change and rebuild,
// bench_cut_event): a soft material, the bottom face (y = 0) fixed, 10 CG iterations always, and
// the room for cuts `blobvk cut` reserves.
#pragma once

#include "blobvk/fem/simulation.h"

namespace blobvk::bench {

inline fem::SimulationSettings cutBlockSettings() {
  fem::SimulationSettings settings;
  settings.materials = {fem::Material{1e5, 0.45, 1000}};
  settings.fixed = [](const mesh::Double3& p) { return p.y < 1e-9; };
  settings.cgMaxIterations = 10;
  settings.cgTolerance = 0;
  settings.cutRoom = 0.5;  // as blobvk cut
  return settings;
}

}  // namespace blobvk::bench
