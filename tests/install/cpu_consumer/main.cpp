// Meshes a scene with the installed blobvk::cpu (MPU polygonizer) and checks the result against
// the scalar reference polygonizer and, for the sphere the install test writes, the analytic
// volume. Exit 0 when all holds.
#include <blobvk/blobtree/grid.h>
#include <blobvk/blobtree/program.h>
#include <blobvk/blobtree/scene_io.h>
#include <blobvk/cpu_simd/mpu_polygonizer.h>
#include <blobvk/cpu_simd/reference_polygonizer.h>
#include <blobvk/mesh/checks.h>

#include <cmath>
#include <cstdio>
#include <numbers>

int main(int argc, char** argv) {
  if (argc != 2) return 2;
  using namespace blobvk;
  const blobtree::Scene scene = blobtree::loadScene(argv[1]);
  const blobtree::Program program = blobtree::compile(scene.root);
  const blobtree::GridSpec grid = blobtree::chooseGrid(program, scene.grid, {std::nullopt, 64});
  const mesh::TriMesh mesh = cpu::polygonizeMpu(program, grid, {});
  const mesh::TriMesh reference = cpu::polygonizeReference(program, grid, {});
  const mesh::MeshReport report = mesh::checkMesh(mesh);
  // The surface of a point of support R: (1 - (d/R)^2)^3 = 0.5.
  const double radius = 2.0 * std::sqrt(1.0 - std::cbrt(0.5));
  const double sphere = 4.0 / 3.0 * std::numbers::pi * radius * radius * radius;
  std::printf("%zu triangles, %s; volume %.5f (sphere %.5f)\n", mesh.triangleCount(), report.summary().c_str(),
              report.volume, sphere);
  if (!report.watertight() || mesh.triangleCount() < 1000) return 1;
  if (std::abs(report.volume - sphere) > 0.01 * sphere) return 1;
  if (mesh.triangles != reference.triangles || mesh.edgeKeys != reference.edgeKeys) {
    std::printf("the MPU mesh differs from the reference mesh\n");
    return 1;
  }
  return 0;
}
