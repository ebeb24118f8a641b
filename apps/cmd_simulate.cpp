// `blobvk simulate SCENE --steps N -o frames/`: the scene as a soft body pressed by its tools;
// one PLY of the render surface per frame.
#include "body_size_check.h"
#include "number_checks.h"
#include "cli_conventions.h"
#include "divergence_check.h"
#include "commands.h"
#include "resolution_limit.h"
#include "frame_writer.h"
#include "model.h"
#include "progress.h"

#include "blobvk/mesh/io.h"
#include "blobvk/surgery/tet_model.h"

#include <CLI/CLI.hpp>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>

namespace blobvk::app {

void addSimulateCommand(CLI::App& app) {
  struct Args {
    std::string scene, out;
    int steps = 0, threads = 0, frameEvery = 0;
    std::optional<float> cellSize;
    std::optional<int> resolution;
    bool noPng = false;
    int imageSize = 768;
  };
  auto a = std::make_shared<Args>();
  auto* cmd = app.add_subcommand("simulate", "Run the scene's soft-body simulation, writing frames");
  cmd->add_option("scene", a->scene, "Scene with a \"simulation\" section")->required();
  cmd->add_option("-o,--output", a->out, "Folder for frame_NNNNN.ply")->required();
  cmd->add_option("--steps", a->steps, "Time steps (default: the scene's, else 100)")->check(CLI::Range(1, 10000000));
  cmd->add_option("--frame-every", a->frameEvery, "Write a frame every K steps")->check(CLI::Range(1, 1000000));
  auto* resolution = cmd->add_option("--resolution", a->resolution, "Polygonization cells along the longest side (default: the scene's grid, else 48)")
                         ->check(resolutionRange(4));
  cmd->add_option("--cell-size", a->cellSize, "Polygonization cell size")->check(cellSize())->excludes(resolution);
  cmd->add_option("--threads", a->threads, "CPU threads for polygonization (0 = all)")->check(CLI::Range(0, 1024));
  auto* imageSize = cmd->add_option("--image-size", a->imageSize, "PNG frame side in pixels")->check(CLI::Range(16, kMaxImageSide));
  cmd->add_flag("--no-png", a->noPng, "Write PLY frames only (PNG frames need a Vulkan device)")->excludes(imageSize);
  cmd->callback([a, imageSize] {
    checkOutputFolder(a->out);  // the output place first, as every command does
    const Model model = loadModel(a->scene);
    const surgery::SceneModel sceneModel{model.path, model.scene, model.program};
    surgery::simulationConfigOf(sceneModel);  // the simulation section's mistakes too
    // The renderer and the folder before the (long) tetrahedralization, once the scene has
    // loaded (a scene that fails leaves nothing behind).
    FrameWriter frames(a->out, !a->noPng, imageSize->count() > 0, a->imageSize, model.program.bounds, model.scene.camera);
    // The scene's grid when it gives one (TetGen meshes that surface), else 48 cells.
    const bool sceneGrid = model.scene.grid.resolution || model.scene.grid.cellSize;
    const blobtree::GridSpec grid = gridFor(model, a->cellSize, a->resolution ? a->resolution : sceneGrid ? std::nullopt : std::optional<int>(48));
    Progress::note("simulate", "polygonizing and tetrahedralizing " + a->scene);
    surgery::TetModel body = surgery::buildTetModel(sceneModel, grid, {a->threads, {}});
    warnIfCoarseBody(body, a->scene, "");
    fem::Simulation sim(std::move(body.tets), body.config.settings);
    if (!body.renderTetBoundary) sim.setRenderSurface(body.surface, std::move(body.embedding));
    const int steps = a->steps ? a->steps : (body.config.steps ? body.config.steps : 100);
    const int every = a->frameEvery ? a->frameEvery : body.config.frameEvery;
    if (!quiet()) std::fprintf(stderr, "%s: %zu triangles -> %zu tets, %zu nodes (%s); mesh %.4f s, tets %.2f s\n",
                 a->scene.c_str(), body.surface.triangleCount(), sim.mesh().tetCount(), sim.mesh().nodeCount(),
                 body.config.mesher.c_str(), body.meshSeconds, body.tetSeconds);
    sim.setWarningHandler([](const std::string& line) { std::fprintf(stderr, "%s\n", line.c_str()); });
    Progress progress("simulate", steps);
    double totalMs = 0, maxForce = 0;
    frames.write(sim.renderSurface());
    const DivergenceCheck divergence(sim, a->scene);
    for (int s = 1; s <= steps; ++s) {
      sim.step();
      totalMs += sim.lastStats().totalMs;
      for (const auto& c : sim.toolContacts()) {
        maxForce = std::max(maxForce, std::sqrt(c.force.x * c.force.x + c.force.y * c.force.y + c.force.z * c.force.z));
      }
      divergence.check(sim, s, "reduce timeStep or the tools' stiffness, or raise the materials' E");
      if (s % every == 0 || s == steps) frames.write(sim.renderSurface());
      char note[64];
      std::snprintf(note, sizeof note, "%.2f ms/step", totalMs / s);
      progress.update(s, note);
    }
    std::printf("%d steps, %d frames (%s) in %s; %.3f ms/step; max tool force %.4g N; volume %.4g (rest %.4g)\n", steps,
                frames.frames(), frames.writesPng() ? "PLY + PNG" : "PLY", a->out.c_str(), totalMs / steps, maxForce, sim.currentVolume(), sim.restVolume());
    const fem::SolverSummary& cg = sim.solverSummary();
    std::printf("CG: %.1f iterations/step (max %d), max relative residual %.3g (tolerance %.3g), %lld steps at the cap\n",
                double(cg.iterations) / double(std::max(1LL, cg.steps)), cg.maxIterations, cg.maxRelativeResidual,
                sim.settings().cgTolerance, cg.capHits);
  });
}

}  // namespace blobvk::app
