// `blobvk cut SCENE -o frames/`: one simulation in which the scene's blade (simulation.blade, or
// --blade path.json; keyframe times are simulation times) cuts the soft body while it moves,
// each cut event updating the running FEM; the scripted lift (simulation.lift) carries a freed
// part away and the tools press throughout. Writes frame_NNNNN.ply (+ .png with a Vulkan
// device, + .vtu with --vtu: the tet mesh with regions, parts and displacements) and stats.csv:
// per frame the time, cut events so far, parts, the lift and every tool's force and contact
// nodes, FEM and cut milliseconds, the FEM solver's iterations and residual.
#include "body_size_check.h"
#include "number_checks.h"
#include "cli_conventions.h"
#include "commands.h"
#include "divergence_check.h"
#include "resolution_limit.h"
#include "frame_writer.h"
#include "model.h"
#include "progress.h"

#include "blobvk/cutting/quality.h"
#include "blobvk/surgery/scripted_procedure.h"
#include "blobvk/surgery/tet_model.h"
#include "blobvk/surgery/vtu_writer.h"

#include <CLI/CLI.hpp>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>

namespace blobvk::app {
namespace {

using surgery::BladeKeyframe;

// --blade file: {"blade": [{"t":0, "a":[..], "b":[..]}, ...]}, validated by the same parser.
std::vector<BladeKeyframe> readBladeFile(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) throw std::runtime_error(path + ": is a directory, not a blade path file");
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open the blade path file: " + systemReason(errno));
  std::string text;
  try {
    text.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  } catch (const std::ios_base::failure&) {  // libstdc++ throws from a read that fails
    throw std::runtime_error(path + ": cannot read the blade path file: " + systemReason(errno));
  }
  return surgery::parseBladePath(text, path);
}

double norm(const mesh::Double3& v) { return std::sqrt(v.x * v.x + v.y * v.y + v.z * v.z); }

// Per-tool extremes over the run, for the summary on stdout.
struct ToolSummary {
  double maxForce = 0, maxForceAfterLift = 0;
  std::size_t maxNodes = 0;
};

}  // namespace

void addCutCommand(CLI::App& app) {
  struct Args {
    std::string scene, out, blade;
    int steps = 0, frameEvery = 0, threads = 0;
    std::optional<int> resolution;
    std::optional<double> voxelCell;
    bool noPng = false, checkEachEvent = false, vtu = false;
    std::string fragments = "remove";
    std::optional<int> fragmentTets;
    int imageSize = 768;
  };
  auto a = std::make_shared<Args>();
  auto* cmd = app.add_subcommand("cut", "Simulate the scene's soft body while its blade cuts it (and its lift, tools act)");
  cmd->add_option("scene", a->scene, "Scene with a \"simulation\" section")->required();
  cmd->add_option("-o,--output", a->out, "Folder for frame_NNNNN.ply and stats.csv")->required();
  cmd->add_option("--blade", a->blade, "Blade path JSON (default: the scene's simulation.blade)");
  cmd->add_option("--steps", a->steps, "Time steps of the whole run (default: the scene's, else 60)")->check(CLI::Range(1, 10000000));
  cmd->add_option("--frame-every", a->frameEvery, "Write a frame every K steps")->check(CLI::Range(1, 1000000));
  cmd->add_option("--resolution", a->resolution, "Polygonization cells along the longest side (default: the scene's grid, else 48)")->check(resolutionRange(4));
  cmd->add_option("--voxel-cell", a->voxelCell, "Voxel mesher cell size (default: the scene's simulation.voxel.cellSize)")->check(positiveFinite());
  cmd->add_option("--threads", a->threads, "CPU threads for polygonization (0 = all)")->check(CLI::Range(0, 1024));
  cmd->add_option("--fragments", a->fragments, "Parts much smaller than the body: remove (resect them) or keep; reported either way")
      ->check(CLI::IsMember({"remove", "keep"}));
  cmd->add_option("--fragment-tets", a->fragmentTets, "A part (not the largest) of at most this many tets is a fragment (default: 0.2 % of the body's tets)")
      ->check(CLI::Range(0, 100000000));
  cmd->add_flag("--check-each-event", a->checkEachEvent, "Run the O(n) topology self-check after every cut event");
  cmd->add_flag("--vtu", a->vtu, "Also write frame_NNNNN.vtu: the tet mesh with regions, parts and node displacements (ParaView)");
  auto* imageSize = cmd->add_option("--image-size", a->imageSize, "PNG frame side in pixels")->check(CLI::Range(16, kMaxImageSide));
  cmd->add_flag("--no-png", a->noPng, "Write PLY frames only (PNG frames need a Vulkan device)")->excludes(imageSize);
  cmd->callback([a, imageSize] {
    checkOutputFolder(a->out);  // the output place first, as every command does
    const Model model = loadModel(a->scene);
    const surgery::SceneModel sceneModel{model.path, model.scene, model.program};
    // The simulation section and the blade file too: their mistakes, and a missing blade path,
    // are found before the folder is made and the tetrahedralization runs.
    const surgery::SimulationConfig config = surgery::simulationConfigOf(sceneModel);
    if (a->voxelCell && config.mesher != "voxel")  // an option that would do nothing is refused
      throw UsageError("--voxel-cell is for the voxel mesher; " + a->scene + " is meshed with " + config.mesher +
                       " (simulation.mesher)");
    const std::vector<BladeKeyframe> keys = a->blade.empty() ? config.blade : readBladeFile(a->blade);
    if (keys.size() < 2) {
      throw std::runtime_error(a->scene + ": /simulation/blade: no blade path (give one in the scene or with --blade)");
    }
    // The renderer and the folder before the (long) tetrahedralization, once the inputs have
    // loaded (inputs that fail leave nothing behind).
    FrameWriter frames(a->out, !a->noPng, imageSize->count() > 0, a->imageSize, model.program.bounds, model.scene.camera);
    // The scene's grid (its surface is what TetGen meshes: a thin shell needs the resolution the
    // scene asks for), else 48 cells along the longest side.
    const bool sceneGrid = model.scene.grid.resolution || model.scene.grid.cellSize;
    const blobtree::GridSpec grid = gridFor(model, std::nullopt, a->resolution ? a->resolution : sceneGrid ? std::nullopt : std::optional<int>(48));
    Progress::note("cut", "polygonizing and tetrahedralizing " + a->scene);
    surgery::TetModel body = buildTetModel(sceneModel, grid, {a->threads, a->voxelCell});
    if (!quiet()) std::fprintf(stderr, "%s: %zu triangles -> %zu tets, %zu nodes (%s); mesh %.2f s, tets %.2f s\n", a->scene.c_str(),
                 body.surface.triangleCount(), body.tets.tetCount(), body.tets.nodeCount(), body.config.mesher.c_str(),
                 body.meshSeconds, body.tetSeconds);
    warnIfCoarseBody(body, a->scene, "--voxel-cell");
    const cutting::QualityStats before = cutting::meshQuality(body.tets);
    surgery::SoftBodyOptions options;
    options.checkEachEvent = a->checkEachEvent;
    options.fragments.action = a->fragments == "keep" ? surgery::FragmentPolicy::Action::Keep : surgery::FragmentPolicy::Action::Remove;
    if (a->fragmentTets) {  // the given size alone, in place of the default fraction
      options.fragments.maxTets = std::size_t(*a->fragmentTets);
      options.fragments.maxFraction = 0;
    }
    surgery::ScriptedProcedure run(std::move(body.tets), body.config, keys, options);
    surgery::SoftBody& soft = run.body();
    if (!body.renderTetBoundary) soft.setRenderSurface(body.surface, std::move(body.embedding));

    const int steps = a->steps ? a->steps : (body.config.steps ? body.config.steps : 60);
    const int every = a->frameEvery ? a->frameEvery : body.config.frameEvery;
    const std::size_t toolCount = body.config.settings.tools.size();
    const std::string statsPath = (std::filesystem::path(a->out) / "stats.csv").string();
    std::ofstream stats(statsPath);
    if (!stats) throw std::runtime_error(statsPath + ": cannot write");
    stats << "frame,step,time,cut_events,parts,lifted,lift_distance,fem_ms,cut_ms,cg_iterations,cg_residual";
    for (std::size_t k = 0; k < toolCount; ++k) stats << ",tool" << k << "_force,tool" << k << "_nodes";
    stats << "\n";
    double femMsSinceFrame = 0, cutMsSinceFrame = 0, femMsTotal = 0, cgIterationsSinceFrame = 0, cgResidualSinceFrame = 0;
    int stepsSinceFrame = 0;
    std::vector<ToolSummary> tools(toolCount);
    auto writeFrame = [&](int step) {
      stats << frames.frames() << ',' << step << ',' << soft.time() << ',' << soft.events() << ',' << soft.parts().size() << ','
            << (run.lift() && run.lift()->started() ? 1 : 0) << ',' << (run.lift() ? run.lift()->distanceFromRest(soft.simulation()) : 0.0)
            << ',' << (stepsSinceFrame ? femMsSinceFrame / stepsSinceFrame : 0.0) << ',' << cutMsSinceFrame << ','
            << (stepsSinceFrame ? cgIterationsSinceFrame / stepsSinceFrame : 0.0) << ',' << cgResidualSinceFrame;
      for (std::size_t k = 0; k < toolCount; ++k) {
        const auto& c = step > 0 ? soft.simulation().toolContacts()[k] : fem::ToolContactReport{};
        stats << ',' << norm(c.force) << ',' << c.nodesInContact;
      }
      stats << "\n";
      femMsSinceFrame = cutMsSinceFrame = cgIterationsSinceFrame = cgResidualSinceFrame = 0;
      stepsSinceFrame = 0;
      if (a->vtu) {
        char name[32];
        std::snprintf(name, sizeof name, "frame_%05d.vtu", frames.frames());
        surgery::writeVtu((std::filesystem::path(a->out) / name).string(), soft.mesh(), soft.parts());
      }
      frames.write(colourByRegion(soft.simulation().renderSurface(), soft.simulation().mesh(), model.program));
    };
    writeFrame(0);
    Progress progress("cut+simulate", steps);
    const DivergenceCheck divergence(soft.simulation(), a->scene);
    for (int s = 1; s <= steps; ++s) {
      run.step();
      divergence.check(soft.simulation(), s, "reduce timeStep or the tools' stiffness, or raise the materials' E");
      femMsSinceFrame += soft.lastStepFemMs();
      femMsTotal += soft.lastStepFemMs();
      cutMsSinceFrame += soft.lastStepCutMs();
      // The FEM's linear solve: mean CG iterations per step and the largest relative residual
      // it stopped at, since the previous frame.
      cgIterationsSinceFrame += soft.simulation().lastStats().cgIterations;
      cgResidualSinceFrame = fem::worseResidual(cgResidualSinceFrame, soft.simulation().lastStats().cgRelativeResidual);
      ++stepsSinceFrame;
      const bool lifted = run.lift() && run.lift()->started();
      for (std::size_t k = 0; k < toolCount; ++k) {
        const fem::ToolContactReport& c = soft.simulation().toolContacts()[k];
        tools[k].maxForce = std::max(tools[k].maxForce, norm(c.force));
        if (lifted) tools[k].maxForceAfterLift = std::max(tools[k].maxForceAfterLift, norm(c.force));
        tools[k].maxNodes = std::max(tools[k].maxNodes, c.nodesInContact);
      }
      if (s % every == 0 || s == steps) writeFrame(s);
      char note[96];
      std::snprintf(note, sizeof note, "%.2f ms/step, %zu events, %zu parts", femMsTotal / s, soft.events(), soft.parts().size());
      progress.update(s, note);
    }

    const cutting::SelfCheckReport check = soft.topology().selfCheck();
    const cutting::QualityStats after = cutting::meshQuality(soft.topology().toTetMesh());
    std::string checkText = check.ok() ? "ok" : check.summary();
    if (a->checkEachEvent && check.ok()) checkText += " (and after each of " + std::to_string(soft.checksPassed()) + " changing events)";
    std::printf("cut: %zu events in %.1f ms, %zu parts; self-check %s; cutter %.1f ms, FEM updates %.1f ms, %zu tets split\n",
                soft.events(), soft.cutMs() + soft.updateMs(), soft.parts().size(), checkText.c_str(), soft.cutMs(), soft.updateMs(),
                soft.splitTets());
    std::string sizes;
    for (std::size_t p = 0; p < soft.parts().size() && p < 8; ++p) sizes += (p ? ", " : "") + std::to_string(soft.parts()[p].size());
    std::printf("parts (tets): %s%s\n", sizes.c_str(), soft.parts().size() > 8 ? ", ..." : "");
    std::size_t removedTets = 0, keptTets = 0, removedCount = 0, keptCount = 0;
    for (const surgery::FragmentReport& f : soft.fragments()) {
      (f.removed ? removedTets : keptTets) += f.tets;
      ++(f.removed ? removedCount : keptCount);
    }
    std::printf("fragments: %zu removed (%zu tets), %zu kept (%zu tets)\n", removedCount, removedTets, keptCount, keptTets);
    std::printf("quality before: %s\nquality after:  %s\n", before.summary().c_str(), after.summary().c_str());
    if (const surgery::RigidLift* lift = run.lift()) {
      if (lift->started()) {
        std::printf("lift: a part of %zu tets (%zu nodes) came free and was lifted from t = %.3f s; it ends %.4g from its rest place (path %.4g)\n",
                    lift->tetCount(), lift->nodeCount(), lift->startTime(), lift->distanceFromRest(soft.simulation()), lift->pathDistance());
      } else {
        std::printf("lift: not started after t = %.3f s: %s\n", lift->earliestStart(), lift->waitingReason(soft.parts(), soft.simulation()).c_str());
      }
    }
    double maxForce = 0;
    for (std::size_t k = 0; k < toolCount; ++k) {
      std::printf("tool %zu: max force %.4g N, %.4g N after the lift; up to %zu nodes in contact\n", k, tools[k].maxForce,
                  tools[k].maxForceAfterLift, tools[k].maxNodes);
      maxForce = std::max(maxForce, tools[k].maxForce);
    }
    std::printf("%d steps, %d frames (%s) in %s; %.3f ms/step; max tool force %.4g N; %zu tets, %zu nodes; stats in %s\n", steps,
                frames.frames(), frames.writesPng() ? "PLY + PNG" : "PLY", a->out.c_str(), femMsTotal / steps, maxForce,
                soft.simulation().mesh().tetCount(), soft.simulation().mesh().nodeCount(), statsPath.c_str());
    if (!check.ok()) throw std::runtime_error("the cut mesh failed its self-check: " + check.summary());
  });
}

}  // namespace blobvk::app
