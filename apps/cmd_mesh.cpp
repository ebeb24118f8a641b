// `blobvk mesh SCENE -o out.ply`: polygonize a scene and write the mesh.
#include "backends.h"
#include "commands.h"
#include "model.h"
#include "resource_limits.h"

#include "mesh/checks.h"
#include "mesh/io.h"

#include <CLI/CLI.hpp>

#include <cstdio>
#include <memory>
#include <optional>

namespace blobvk::app {

void addMeshCommand(CLI::App& app) {
  struct Args {
    std::string scene, out;
    std::optional<float> cellSize;
    std::optional<int> resolution;
    PolygonizeSettings settings;
    bool ascii = false, quiet = false;
    std::string maxMemory;
    Limits limits;
  };
  auto a = std::make_shared<Args>();
  auto* cmd = app.add_subcommand("mesh", "Polygonize a scene into a mesh (.ply, .obj, .stl)");
  cmd->add_option("scene", a->scene, "Scene file (.json, .blob, .scene)")->required();
  cmd->add_option("-o,--output", a->out, "Output mesh (.ply, .obj, .stl)")->required();
  auto* cs = cmd->add_option("--cell-size", a->cellSize, "Grid cell size (world units)")
                 ->check(CLI::PositiveNumber);
  cmd->add_option("--resolution", a->resolution, "Cells along the longest side of the model")
      ->check(CLI::Range(1, 65536))
      ->excludes(cs);
  cmd->add_option("--backend", a->settings.backend, "cpu (default), reference or vk");
  cmd->add_option("--threads", a->settings.threads, "CPU threads (0 = all cores)")
      ->check(CLI::Range(0, 1024));
  cmd->add_option("--mpu", a->settings.mpuSize, "Cells per MPU side (cpu backend; 0 = default)")
      ->check(CLI::Range(0, 64));
  cmd->add_option("--refine", a->settings.refineSteps, "Root refinement steps per vertex")
      ->check(CLI::Range(0, 16));
  cmd->add_option("--device", a->settings.device, "Vulkan device (name substring or index)");
  cmd->add_flag("--validation", a->settings.validation, "Enable the Vulkan validation layer");
  cmd->add_option("--traversal", a->settings.traversal, "vk: auto (default: the cost model picks per job), specialised, stackless or stack")
      ->check(CLI::IsMember(traversalNames()));
  cmd->add_option("--field-tiles", a->settings.fieldTiles,
                  "vk specialised: most grid tiles with their own pruned field kernel (1 = one kernel; default 8)")
      ->check(CLI::Range(1, 256));
  cmd->add_flag("--tiled-vertices", a->settings.tiledVertices,
                "vk specialised: run the vertex pass per field tile too (faster when repeated, slower to start)");
  cmd->add_option("--max-memory", a->maxMemory, "Refuse jobs needing more (e.g. 2G; default: available)");
  cmd->add_option("--max-triangles", a->limits.maxTriangles, "Refuse meshes with more triangles");
  cmd->add_flag("--ascii", a->ascii, "Write ASCII PLY instead of binary");
  cmd->add_flag("-q,--quiet", a->quiet, "Print nothing on success");
  cmd->callback([a] {
    const Model model = loadModel(a->scene);
    const blobtree::GridSpec grid = gridFor(model, a->cellSize, a->resolution);
    if (!a->maxMemory.empty()) a->limits.maxMemoryBytes = parseByteSize(a->maxMemory);
    checkMemory(estimatePolygonizeBytes(grid, a->settings.backend), a->limits,
                "a " + std::to_string(grid.cells.x) + " x " + std::to_string(grid.cells.y) + " x " +
                    std::to_string(grid.cells.z) + " grid");
    PolygonizeStats stats;
    const mesh::TriMesh mesh = polygonize(model.program, grid, a->settings, &stats);
    checkTriangles(mesh.triangleCount(), a->limits);
    if (a->ascii) mesh::writePly(mesh, a->out, false);
    else mesh::writeMesh(mesh, a->out);
    if (!a->quiet) {
      const mesh::MeshReport report = mesh::checkMesh(mesh);
      std::printf("%s: %d x %d x %d cells of %.4g, backend %s, %.3f s\n", a->out.c_str(),
                  grid.cells.x, grid.cells.y, grid.cells.z, grid.cellSize,
                  a->settings.backend.c_str(), stats.seconds);
      std::printf("%s\n", report.summary().c_str());
    }
  });
}

}  // namespace blobvk::app
