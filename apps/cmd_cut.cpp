// `blobvk cut SCENE -o frames/`: one simulation in which the scene's blade (simulation.blade, or
// --blade path.json; keyframe times are simulation times) cuts the soft body while it moves,
// each cut event updating the running FEM; the scripted lift (simulation.lift) carries a freed
// part away and the tools press throughout. Writes frame_NNNNN.ply (+ .png with a Vulkan
// device) and stats.csv: per frame the time, cut events so far, parts, the lift and every
// tool's force and contact nodes, FEM and cut milliseconds.
#include "cli_conventions.h"
#include "commands.h"
#include "resolution_limit.h"
#include "cut_simulation.h"
#include "frame_writer.h"
#include "model.h"
#include "progress.h"
#include "soft_body.h"

#include "blobvk/cutting/quality.h"

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>

namespace blobvk::app {
namespace {

// --blade file: {"blade": [{"t":0, "a":[..], "b":[..]}, ...]}, validated by the same parser.
std::vector<BladeKeyframe> readBladeFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open the blade path file: " + systemReason(errno));
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(in);
  } catch (const nlohmann::json::parse_error& e) {
    throw std::runtime_error(path + ": malformed JSON: " + e.what());
  }
  if (!j.is_object() || !j.contains("blade")) throw std::runtime_error(path + ": expected an object with a \"blade\" array");
  return parseSimulationConfig(nlohmann::json{{"blade", j["blade"]}}.dump(), path).blade;
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
    bool noPng = false, checkEachEvent = false;
    int imageSize = 384;
  };
  auto a = std::make_shared<Args>();
  auto* cmd = app.add_subcommand("cut", "Simulate the scene's soft body while its blade cuts it (and its lift, tools act)");
  cmd->add_option("scene", a->scene, "Scene with a \"simulation\" section")->required();
  cmd->add_option("-o,--output", a->out, "Folder for frame_NNNNN.ply and stats.csv")->required();
  cmd->add_option("--blade", a->blade, "Blade path JSON (default: the scene's simulation.blade)");
  cmd->add_option("--steps", a->steps, "Time steps of the whole run (default: the scene's, else 60)")->check(CLI::Range(1, 10000000));
  cmd->add_option("--frame-every", a->frameEvery, "Write a frame every K steps")->check(CLI::Range(1, 1000000));
  cmd->add_option("--resolution", a->resolution, "Polygonization cells along the longest side")->check(resolutionRange(4));
  cmd->add_option("--voxel-cell", a->voxelCell, "Voxel mesher cell size (default: the scene's simulation.voxel.cellSize)")->check(CLI::PositiveNumber);
  cmd->add_option("--threads", a->threads, "CPU threads for polygonization (0 = all)")->check(CLI::Range(0, 1024));
  cmd->add_flag("--check-each-event", a->checkEachEvent, "Run the O(n) topology self-check after every cut event");
  cmd->add_flag("--no-png", a->noPng, "Write PLY frames only (PNG frames need a Vulkan device)");
  cmd->add_option("--image-size", a->imageSize, "PNG frame side in pixels")->check(CLI::Range(16, kMaxImageSide));
  cmd->callback([a] {
    prepareOutputFolder(a->out);  // before the (long) tetrahedralization
    const Model model = loadModel(a->scene);
    const blobtree::GridSpec grid = gridFor(model, std::nullopt, a->resolution.value_or(48));
    Progress::note("cut", "polygonizing and tetrahedralizing " + a->scene);
    TetModel body = buildTetModel(model, grid, a->threads, a->voxelCell);
    const std::vector<BladeKeyframe> keys = a->blade.empty() ? body.config.blade : readBladeFile(a->blade);
    if (keys.size() < 2) {
      throw std::runtime_error(a->scene + ": /simulation/blade: no blade path (give one in the scene or with --blade)");
    }
    if (!quiet()) std::fprintf(stderr, "%s: %zu triangles -> %zu tets, %zu nodes (%s); mesh %.2f s, tets %.2f s\n", a->scene.c_str(),
                 body.surface.triangleCount(), body.tets.tetCount(), body.tets.nodeCount(), body.config.mesher.c_str(),
                 body.meshSeconds, body.tetSeconds);
    const cutting::QualityStats before = cutting::meshQuality(body.tets);
    CutSimulationOptions options;
    options.checkEachEvent = a->checkEachEvent;
    CutSimulation run(std::move(body.tets), body.config, keys, options);
    run.setRenderSurface(body.surface, std::move(body.embedding));
    const fem::Simulation& sim = run.simulation();

    const int steps = a->steps ? a->steps : (body.config.steps ? body.config.steps : 60);
    const int every = a->frameEvery ? a->frameEvery : body.config.frameEvery;
    const std::size_t toolCount = body.config.settings.tools.size();
    FrameWriter frames(a->out, !a->noPng, a->imageSize, model.program.bounds, model.scene.camera);
    const std::string statsPath = (std::filesystem::path(a->out) / "stats.csv").string();
    std::ofstream stats(statsPath);
    if (!stats) throw std::runtime_error(statsPath + ": cannot write");
    stats << "frame,step,time,cut_events,parts,lifted,lift_distance,fem_ms,cut_ms,cg_iterations,cg_rel_residual";
    for (std::size_t k = 0; k < toolCount; ++k) stats << ",tool" << k << "_force,tool" << k << "_nodes";
    stats << "\n";
    double femMsSinceFrame = 0, cutMsSinceFrame = 0, femMsTotal = 0;
    int stepsSinceFrame = 0;
    std::vector<ToolSummary> tools(toolCount);
    auto writeFrame = [&](int step) {
      stats << frames.frames() << ',' << step << ',' << sim.time() << ',' << run.events() << ',' << run.partCount() << ','
            << (run.lift() && run.lift()->started() ? 1 : 0) << ',' << (run.lift() ? run.lift()->distanceFromRest(sim) : 0.0)
            << ',' << (stepsSinceFrame ? femMsSinceFrame / stepsSinceFrame : 0.0) << ',' << cutMsSinceFrame << ','
            << sim.lastStats().cgIterations << ',' << sim.lastStats().cgRelativeResidual;  // the frame's last step
      for (std::size_t k = 0; k < toolCount; ++k) {
        const auto& c = step > 0 ? sim.toolContacts()[k] : fem::ToolContactReport{};
        stats << ',' << norm(c.force) << ',' << c.nodesInContact;
      }
      stats << "\n";
      femMsSinceFrame = cutMsSinceFrame = 0;
      stepsSinceFrame = 0;
      frames.write(colourByRegion(sim.renderSurface(), sim.mesh(), model.program));
    };
    writeFrame(0);
    Progress progress("cut+simulate", steps);
    for (int s = 1; s <= steps; ++s) {
      run.step();
      femMsSinceFrame += run.lastStepFemMs();
      femMsTotal += run.lastStepFemMs();
      cutMsSinceFrame += run.lastStepCutMs();
      ++stepsSinceFrame;
      const bool lifted = run.lift() && run.lift()->started();
      for (std::size_t k = 0; k < toolCount; ++k) {
        const fem::ToolContactReport& c = sim.toolContacts()[k];
        tools[k].maxForce = std::max(tools[k].maxForce, norm(c.force));
        if (lifted) tools[k].maxForceAfterLift = std::max(tools[k].maxForceAfterLift, norm(c.force));
        tools[k].maxNodes = std::max(tools[k].maxNodes, c.nodesInContact);
      }
      if (s % every == 0 || s == steps) writeFrame(s);
      char note[96];
      std::snprintf(note, sizeof note, "%.2f ms/step, %zu events, %zu parts", femMsTotal / s, run.events(), run.partCount());
      progress.update(s, note);
    }

    const cutting::SelfCheckReport check = run.topology().selfCheck();
    const cutting::QualityStats after = cutting::meshQuality(run.topology().toTetMesh());
    std::string checkText = check.ok() ? "ok" : check.summary();
    if (a->checkEachEvent && check.ok()) checkText += " (and after each of " + std::to_string(run.checksPassed()) + " changing events)";
    std::printf("cut: %zu events in %.1f ms, %zu parts; self-check %s; cutter %.1f ms, FEM updates %.1f ms, %zu tets split\n",
                run.events(), run.cutMs() + run.updateMs(), run.partCount(), checkText.c_str(), run.cutMs(), run.updateMs(),
                run.splitTets());
    std::string sizes;
    for (std::size_t p = 0; p < run.parts().size() && p < 8; ++p) sizes += (p ? ", " : "") + std::to_string(run.parts()[p].size());
    std::printf("parts (tets): %s%s\n", sizes.c_str(), run.parts().size() > 8 ? ", ..." : "");
    std::printf("quality before: %s\nquality after:  %s\n", before.summary().c_str(), after.summary().c_str());
    if (const RigidLift* lift = run.lift()) {
      if (lift->started()) {
        std::printf("lift: a part of %zu tets (%zu nodes) came free and was lifted from t = %.3f s; it ends %.4g from its rest place (path %.4g)\n",
                    lift->tetCount(), lift->nodeCount(), lift->startTime(), lift->distanceFromRest(sim), lift->pathDistance());
      } else {
        std::printf("lift: not started after t = %.3f s: %s\n", lift->earliestStart(), lift->waitingReason(run.parts(), sim).c_str());
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
                sim.mesh().tetCount(), sim.mesh().nodeCount(), statsPath.c_str());
    if (!check.ok()) throw std::runtime_error("the cut mesh failed its self-check: " + check.summary());
  });
}

}  // namespace blobvk::app
