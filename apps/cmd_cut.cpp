// `blobvk cut SCENE -o frames/`: cut the scene's soft body along its blade path (the scene's
// simulation.blade, or --blade path.json), then simulate the cut body so the parts separate
// under gravity and the tools, writing a PLY of its boundary per frame.
//
// The FEM is rebuilt once from the cut mesh (cutting::CutResult change sets allow an
// incremental rebuild; the CLI does not use them yet).
#include "commands.h"
#include "frame_writer.h"
#include "model.h"
#include "progress.h"
#include "soft_body.h"

#include "cutting/blade_run.h"
#include "fem/simulation.h"
#include "fem/surface_embedding.h"
#include "mesh/io.h"

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>

namespace blobvk::app {
namespace {

cutting::BladePath bladeFromConfig(const std::vector<BladeKeyframe>& keys) {
  cutting::BladePath path;
  for (const BladeKeyframe& k : keys) path.keyframes.push_back({k.time, k.a, k.b});
  return path;
}

// --blade file: {"blade": [{"t":0, "a":[..], "b":[..]}, ...]}, validated by the same parser.
std::vector<BladeKeyframe> readBladeFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open the blade path file");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(in);
  } catch (const nlohmann::json::parse_error& e) {
    throw std::runtime_error(path + ": malformed JSON: " + e.what());
  }
  if (!j.is_object() || !j.contains("blade")) throw std::runtime_error(path + ": expected an object with a \"blade\" array");
  return parseSimulationConfig(nlohmann::json{{"blade", j["blade"]}}.dump(), path).blade;
}

}  // namespace

void addCutCommand(CLI::App& app) {
  struct Args {
    std::string scene, out, blade;
    int steps = 0, frameEvery = 0, threads = 0;
    std::optional<int> resolution;
    bool noPng = false;
    int imageSize = 384;
  };
  auto a = std::make_shared<Args>();
  auto* cmd = app.add_subcommand("cut", "Cut the scene's soft body along a blade path, then simulate");
  cmd->add_option("scene", a->scene, "Scene with a \"simulation\" section")->required();
  cmd->add_option("-o,--output", a->out, "Folder for frame_NNNNN.ply")->required();
  cmd->add_option("--blade", a->blade, "Blade path JSON (default: the scene's simulation.blade)");
  cmd->add_option("--steps", a->steps, "Time steps after the cut (default: the scene's, else 60)")->check(CLI::Range(0, 10000000));
  cmd->add_option("--frame-every", a->frameEvery, "Write a frame every K steps")->check(CLI::Range(1, 1000000));
  cmd->add_option("--resolution", a->resolution, "Polygonization cells along the longest side")->check(CLI::Range(4, 4096));
  cmd->add_option("--threads", a->threads, "CPU threads for polygonization (0 = all)")->check(CLI::Range(0, 1024));
  cmd->add_flag("--no-png", a->noPng, "Write PLY frames only (PNG frames need a Vulkan device)");
  cmd->add_option("--image-size", a->imageSize, "PNG frame side in pixels")->check(CLI::Range(16, 4096));
  cmd->callback([a] {
    const Model model = loadModel(a->scene);
    const blobtree::GridSpec grid = gridFor(model, std::nullopt, a->resolution.value_or(48));
    TetModel body = buildTetModel(model, grid, a->threads);
    const std::vector<BladeKeyframe> keys = a->blade.empty() ? body.config.blade : readBladeFile(a->blade);
    if (keys.size() < 2) {
      throw std::runtime_error(a->scene + ": /simulation/blade: no blade path (give one in the scene or with --blade)");
    }
    const auto start = std::chrono::steady_clock::now();
    cutting::BladeRunResult cut = cutting::runBladePath(std::move(body.tets), bladeFromConfig(keys));
    const double cutMs = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    std::fprintf(stderr, "cut: %zu events in %.1f ms, %zu parts; self-check %s\n", cut.events.size(), cutMs,
                 cut.parts.size(), cut.finalCheck.ok() ? "ok" : cut.finalCheck.summary().c_str());
    std::fprintf(stderr, "quality before: %s\nquality after:  %s\n", cut.before.summary().c_str(), cut.after.summary().c_str());
    if (!cut.finalCheck.ok()) throw std::runtime_error("the cut mesh failed its self-check: " + cut.finalCheck.summary());

    fem::Simulation sim(std::move(cut.mesh), body.config.settings);
    const int steps = a->steps ? a->steps : (body.config.steps ? body.config.steps : 60);
    const int every = a->frameEvery ? a->frameEvery : body.config.frameEvery;
    FrameWriter frames(a->out, !a->noPng, a->imageSize, model.program.bounds, model.scene.camera);
    auto writeFrame = [&] { frames.write(fem::boundarySurface(sim.mesh())); };
    writeFrame();
    Progress progress("simulate", steps);
    for (int s = 1; s <= steps; ++s) {
      sim.step();
      for (const auto& x : sim.positions()) {
        if (!std::isfinite(x.x) || !std::isfinite(x.y) || !std::isfinite(x.z)) {
          throw std::runtime_error("the simulation diverged at step " + std::to_string(s) + " (NaN)");
        }
      }
      if (s % every == 0 || s == steps) writeFrame();
      progress.update(s);
    }
    std::printf("%zu cut events, %zu parts, %zu tets; %d steps, %d frames in %s\n", cut.events.size(), cut.parts.size(),
                sim.mesh().tetCount(), steps, frames.frames(), a->out.c_str());
  });
}

}  // namespace blobvk::app
