// Tetrahedralizes a scene's field with the installed blobvk::fem (voxel mesher), checks the tet
// volume against the analytic sphere and blobvk::cutting's quality metrics against the grid,
// then lets it fall freely for one step: every node must drop by g * dt^2 (implicit Euler from
// rest with no other force acting on a free body).
#include <blobvk/blobtree/evaluate.h>
#include <blobvk/blobtree/program.h>
#include <blobvk/blobtree/scene_io.h>
#include <blobvk/cutting/quality.h>
#include <blobvk/fem/simulation.h>
#include <blobvk/fem/voxel_mesher.h>

#include <cmath>
#include <cstdio>
#include <numbers>

int main(int argc, char** argv) {
  if (argc != 2) return 2;
  using namespace blobvk;
  const blobtree::Scene scene = blobtree::loadScene(argv[1]);
  const blobtree::Program program = blobtree::compile(scene.root);
  fem::VoxelMesherSettings voxels;
  voxels.boundsMin = {-1.2, -1.2, -1.2};
  voxels.boundsMax = {1.2, 1.2, 1.2};
  voxels.cellSize = 0.1;
  const mesh::TetMesh tets = voxelTetrahedralize(
      [&](double x, double y, double z) { return blobtree::evaluate(program, {float(x), float(y), float(z)}); }, voxels);
  // Volume by the determinant, independently of the library's tet utilities.
  double volume = 0;
  for (const auto& t : tets.tets) {
    const auto &a = tets.positions[t[0]], &b = tets.positions[t[1]], &c = tets.positions[t[2]], &d = tets.positions[t[3]];
    const double ux = b.x - a.x, uy = b.y - a.y, uz = b.z - a.z, vx = c.x - a.x, vy = c.y - a.y, vz = c.z - a.z;
    const double wx = d.x - a.x, wy = d.y - a.y, wz = d.z - a.z;
    volume += std::abs(ux * (vy * wz - vz * wy) - uy * (vx * wz - vz * wx) + uz * (vx * wy - vy * wx)) / 6.0;
  }
  const double radius = 2.0 * std::sqrt(1.0 - std::cbrt(0.5));
  const double sphere = 4.0 / 3.0 * std::numbers::pi * radius * radius * radius;
  // Cells partly inside are kept whole: the voxel body holds the sphere and stays within a
  // cell's diagonal of it.
  const double outer = 4.0 / 3.0 * std::numbers::pi * std::pow(radius + voxels.cellSize * std::sqrt(3.0), 3.0);
  std::printf("%zu tets, volume %.4f (sphere %.4f, bound %.4f)\n", tets.tetCount(), volume, sphere, outer);
  if (tets.tetCount() < 100 || volume < 0.95 * sphere || volume > outer) return 1;
  // The cutting module's quality metrics see the same tets: 6 per cube of side 0.1, so edges from
  // the side to the cube's diagonal.
  const cutting::QualityStats quality = cutting::meshQuality(tets);
  std::printf("quality: %s\n", quality.summary().c_str());
  if (quality.tets != tets.tetCount() || std::abs(quality.totalVolume - volume) > 1e-9 * volume) return 1;
  if (std::abs(quality.minEdge - 0.1) > 1e-9 || std::abs(quality.maxEdge - 0.1 * std::sqrt(3.0)) > 1e-9) return 1;

  fem::SimulationSettings settings;
  settings.rayleighStiffness = 0.0;
  settings.cgTolerance = 1e-12;  // the free-fall check below is exact; the default 1e-3 is for frames
  fem::Simulation sim(tets, settings);
  const auto before = sim.positions();
  sim.step();
  const double expected = settings.gravity.y * settings.timeStep * settings.timeStep;
  double worst = 0;
  for (std::size_t i = 0; i < before.size(); ++i) {
    const auto& p = sim.positions()[i];
    worst = std::max(worst, std::abs((p.y - before[i].y) - expected) + std::abs(p.x - before[i].x) + std::abs(p.z - before[i].z));
  }
  std::printf("one free-fall step: worst deviation from g dt^2 = %.3g\n", worst);
  return worst < 1e-4 * std::abs(expected) ? 0 : 1;
}
