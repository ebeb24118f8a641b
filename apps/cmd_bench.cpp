// `blobvk bench SCENE... [--resolution N...] [--backend B...] [--repeats R] [--json]`:
// whole-scene polygonization timings, a table for people and JSON for machines.
#include "backends.h"
#include "cli_conventions.h"
#include "commands.h"
#include "json_report.h"
#include "progress.h"
#include "resolution_limit.h"
#include "model.h"
#include "number_checks.h"

#include "blobvk/cpu_simd/mpu_polygonizer.h"
#include "blobvk/mesh/io.h"

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace blobvk::app {
namespace {

struct Row {
  std::string scene, backend;
  int resolution = 0, threads = 0;
  double median = 0, min = 0, max = 0;
  double first = 0;  // the first run of the process (vk: includes shader compilation and JIT)
  // vk: untimed, after the first run, the wait for the kernels it left building in the
  // background for later runs (a job does not wait for them: it interprets meanwhile).
  double backgroundWait = 0;
  double steady = -1;  // the fastest run after the first (steady state); < 0: only one run
  std::size_t triangles = 0, vertices = 0;
  double evaluations = 0;
  std::vector<std::pair<std::string, double>> phases;  // of the fastest run (cpu backend)
  double outputSeconds = 0;  // encoding the mesh as binary PLY, once, after the timed runs
  PolygonizeStats::Phases gpu;  // vk: of the median run
  nlohmann::json device;        // vk: the device(s) and driver (backendDeviceJson); null otherwise
};

}  // namespace

void addBenchCommand(CLI::App& app) {
  struct Args {
    std::vector<std::string> scenes;
    std::string bounds;
    std::vector<int> resolutions{128};
    std::vector<std::string> backends{"cpu"};
    std::vector<int> threads{0};
    int batchesPerDevice = 0;
    int repeats = 5, warmup = 1, mpuSize = 0, subBlock = -1, fieldTiles = 0, brickCells = 0;
    bool dense = false;
    bool tiledVertices = false;
    bool vertexTiles = false;
    bool brickTapes = false;
    bool noRowCulling = false;
    bool devicePasses = false;
    std::string device;
    std::vector<std::string> deviceLists{""};
    std::vector<std::string> traversals{"auto"};
    bool json = false;
  };
  auto a = std::make_shared<Args>();
  auto* cmd = app.add_subcommand("bench", "Time whole-scene polygonization (median of repeats)");
  cmd->add_option("scenes", a->scenes, "Scene files (.json, .blob, .scene)")->required();
  cmd->add_option("--bounds", a->bounds, kGridBoundsHelp)->check(gridBounds());
  cmd->add_option("--resolution", a->resolutions, "Cells along the longest side (several allowed)")
      ->check(resolutionRange());
  cmd->add_option("--backend", a->backends, "Backends to run: cpu, reference, vk (several allowed)")
      ->check(CLI::IsMember(allBackendNames()));
  cmd->add_option("--threads", a->threads, "CPU thread counts (0 = all; several allowed)")
      ->check(CLI::Range(0, 1024));
  cmd->add_option("--repeats", a->repeats, "Timed runs per configuration")->check(CLI::Range(1, 1000));
  cmd->add_option("--warmup", a->warmup, "Untimed runs first")->check(CLI::Range(0, 100));
  cmd->add_option("--mpu", a->mpuSize, "Cells per MPU side (cpu; 0 = default, 24)")->check(mpuCells());
  cmd->add_option("--sub-block", a->subBlock,
                  "cpu: cells per leaf block of the sparse field cache (0 = every grid point; default 3, or 4 with --mpu)")
      ->check(CLI::Range(0, 64));
  auto* one = cmd->add_option("--device", a->device, "Vulkan device (name substring or index)")->check(nonEmptyText());
  cmd->add_option("--devices", a->deviceLists,
                  "vk: device lists to compare, each as `mesh --devices` (all, or 0,1; a device named twice is opened "
                  "twice; several allowed: --devices 0 --devices 0,0)")
      ->check(nonEmptyText())
      ->excludes(one);
  cmd->add_option("--batches-per-device", a->batchesPerDevice,
                  "vk, several devices: batches of brick layers per device (0: the library's default, 1)")
      ->check(CLI::Range(0, 1024));
  cmd->add_option("--traversal", a->traversals,
                  "vk: auto (default: the cost model picks per job), specialised, stackless, stack (several allowed; stackless vs stack is the thesis' Table 4.2)")
      ->check(CLI::IsMember(traversalNames()));
  cmd->add_option("--brick-cells", a->brickCells,
                  "vk: cells per brick edge of the sparse extraction, 2 to 16, a power of two (0 = default, as mesh)")
      ->check(CLI::IsMember({0, 2, 4, 8, 16}));
  cmd->add_flag("--dense", a->dense, "vk: the dense z-slab extraction (every grid point) instead of the sparse one");
  cmd->add_option("--field-tiles", a->fieldTiles,
                  "vk specialised: most grid tiles with their own pruned field kernel (1 = one kernel; default 8, "
                  "up to 16 for repeated jobs, and up to 128 where a long program's tiles would otherwise loop, where "
                  "the cost model says they pay; a given N caps them all)")
      ->check(CLI::Range(1, 256));
  cmd->add_flag("--tiled-vertices", a->tiledVertices,
                "vk --dense, specialised: the dense pipeline's vertex pass per field tile (the sparse extraction's is "
                "--vertex-tiles)");
  cmd->add_flag("--vertex-tiles", a->vertexTiles,
                "vk sparse, specialised: run the vertex pass per field tile with pruned kernels (slower to start; "
                "the same mesh)");
  cmd->add_flag("--brick-tapes", a->brickTapes,
                "vk sparse: the field pass interprets, per brick, the program pruned to the brick (the same mesh; "
                "auto takes it on lavapipe for long looped programs where it pays)");
  cmd->add_flag("--no-row-culling", a->noRowCulling,
                "vk sparse on lavapipe: evaluate every row of points of an active brick, not only those the CPU "
                "backend's bound leaves (the same mesh)");
  cmd->add_flag("--device-passes", a->devicePasses,
                "vk sparse on lavapipe: run the bookkeeping passes (classification, scans, row counts, sources, "
                "triangles) as kernels on the device, not on the host (the same mesh)");
  cmd->add_flag("--json", a->json, "Print JSON instead of a table");
  cmd->callback([a, cmd] {
    refuseOptionsNoBackendUses(*cmd, a->backends);
    // Without --dense it would switch the pipeline to the dense one behind the user's back.
    if (a->tiledVertices && !a->dense)
      throw UsageError("--tiled-vertices is for the dense pipeline (--dense); the sparse extraction's vertex pass per "
                       "tile is --vertex-tiles");
    // Every scene is loaded before any is timed: a bad one is found at once, not after minutes.
    std::vector<Model> models;
    models.reserve(a->scenes.size());
    for (const std::string& path : a->scenes) {
      models.push_back(loadModel(path));
      applyGridBounds(models.back(), a->bounds);
    }
    std::vector<Row> rows;
    // One progress step per timed configuration (scenes x resolutions x backends x threads, the
    // traversals counting on vk only).
    long configurations = 0;
    for (const std::string& backend : a->backends)
      configurations += long(a->threads.size()) * long(backend == "vk" ? a->traversals.size() * a->deviceLists.size() : 1);
    Progress progress("bench", configurations * long(a->scenes.size() * a->resolutions.size()));
    for (std::size_t scene = 0; scene < a->scenes.size(); ++scene) {
      const std::string& path = a->scenes[scene];
      const Model& model = models[scene];
      for (int resolution : a->resolutions) {
        const blobtree::GridSpec grid = gridFor(model, std::nullopt, resolution);
        for (const std::string& backend : a->backends) {
          for (int threads : a->threads)
          for (const std::string& traversal : a->traversals)
          for (const std::string& devices : a->deviceLists) {
            // The traversal and devices only matter on the GPU; CPU backends run once.
            if (backend != "vk" && (traversal != a->traversals.front() || devices != a->deviceLists.front())) continue;
            PolygonizeSettings settings;
            settings.backend = backend;
            settings.threads = threads;
            settings.mpuSize = a->mpuSize;
            if (a->subBlock >= 0) settings.subBlockCells = a->subBlock;
            settings.device = a->device;
            if (backend == "vk") settings.devices = devices;
            settings.batchesPerDevice = a->batchesPerDevice;
            checkDeviceList(settings);
            settings.traversal = traversal;
            settings.fieldTiles = a->fieldTiles;
            settings.brickCells = a->brickCells;
            settings.dense = a->dense;
            settings.tiledVertices = a->tiledVertices;
            settings.vertexTiles = a->vertexTiles;
            settings.brickTapes = a->brickTapes;
            settings.rowCulling = !a->noRowCulling;
            settings.hostPasses = !a->devicePasses;
            settings.expectedRuns = a->warmup + a->repeats;
            // Repeats mesh again into the last mesh's arrays (cpu: with one polygonizer; vk on one
            // device: vk::polygonizeInto), as a host re-meshing does; the first run (first_s)
            // pays for allocation and page faults.
            if (backend == "cpu") settings.cpuPolygonizer = std::make_shared<cpu::MpuPolygonizer>();
            const std::string label = backend == "vk" ? backend + "-" + traversal + (devices.empty() ? "" : "@" + devices) : backend;
            Row row{path, label, resolution, threads};
            if (backend == "vk") row.device = backendDeviceJson(settings);
            std::vector<std::pair<double, PolygonizeStats::Phases>> times;
            mesh::TriMesh last;
            for (int i = 0; i < a->warmup + a->repeats; ++i) {
              PolygonizeStats stats;
              mesh::TriMesh mesh = polygonize(model.program, grid, settings, &stats, std::move(last));
              if (i == 0) {
                row.first = stats.seconds;
                // The steady state is the one with every kernel built (on a terminal, the bar
                // says what it waits for: a long program's builds take tens of seconds).
                if (backend == "vk")
                  progress.update(long(rows.size()), path + " " + std::to_string(resolution) +
                                                         ": waiting for background kernel builds");
                row.backgroundWait = waitForBackgroundBuilds(settings);
              }
              else row.steady = row.steady < 0 ? stats.seconds : std::min(row.steady, stats.seconds);
              if (i < a->warmup) {
                last = std::move(mesh);
                continue;
              }
              if (times.empty() || stats.seconds < std::min_element(times.begin(), times.end(), [](const auto& x, const auto& y) { return x.first < y.first; })->first)
                row.phases = stats.phaseSeconds;
              times.push_back({stats.seconds, stats.gpu});
              row.triangles = mesh.triangleCount();
              row.vertices = mesh.vertexCount();
              row.evaluations = stats.pointEvaluations;
              last = std::move(mesh);
            }
            // The output phase, as `blobvk mesh -o x.ply` runs it (file writing aside).
            const auto encodeStart = std::chrono::steady_clock::now();
            const std::string bytes = mesh::encodePly(last, true);
            row.outputSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - encodeStart).count();
            std::sort(times.begin(), times.end(), [](const auto& x, const auto& y) { return x.first < y.first; });
            row.median = times[times.size() / 2].first;
            row.gpu = times[times.size() / 2].second;
            row.min = times.front().first;
            row.max = times.back().first;
            rows.push_back(row);
            char note[160];
            std::snprintf(note, sizeof note, "%s %d %s: %.4f s", path.c_str(), resolution, row.backend.c_str(), row.median);
            progress.update(long(rows.size()), note);
          }
        }
      }
    }
    if (a->json) {
      nlohmann::json out = nlohmann::json::array();
      for (const Row& r : rows) {
        nlohmann::json phases = nlohmann::json::object();
        if (r.backend.rfind("vk", 0) == 0) {
          phases = {{"classification_s", r.gpu.classify}, {"field_s", r.gpu.field},
                    {"extraction_s", r.gpu.extract}, {"readback_s", r.gpu.readback},
                    {"readback_device_s", r.gpu.readbackDevice},
                    {"host_s", r.gpu.host}, {"device_timed", r.gpu.deviceTimed}, {"submits", r.gpu.submits},
                    {"batches", r.gpu.batches}, {"devices", r.gpu.devices},
                    {"bricks", r.gpu.bricks}, {"active_bricks", r.gpu.activeBricks},
                    {"brick_cells", r.gpu.brickCells}, {"field_tiles", r.gpu.fieldTiles}, {"vertex_tiles", r.gpu.vertexTiles},
                    {"tape_instructions", r.gpu.tapeInstructions}, {"tape_words", r.gpu.tapeWords},
                    {"tape_s", r.gpu.tapeSeconds},
                    {"generated_classification", r.gpu.generatedClassification}, {"host_classification", r.gpu.hostClassification},
                    {"classify_tiles", r.gpu.classifyTiles},
                    {"device_bytes", r.gpu.deviceBytes},
                    {"extraction_passes_s", {{"edges", r.gpu.edges}, {"scans", r.gpu.scans},
                                             {"sources", r.gpu.sources}, {"vertices", r.gpu.vertices},
                                             {"triangles", r.gpu.triangles}}},
                    {"host_steps", {{"classification", r.gpu.hostSteps.classification},
                                    {"preparation", r.gpu.hostSteps.preparation},
                                    {"field_submits", r.gpu.hostSteps.fieldSubmits},
                                    {"emit_submits", r.gpu.hostSteps.emitSubmits}, {"grow", r.gpu.hostSteps.grow},
                                    {"copy", r.gpu.hostSteps.copy}, {"corners", r.gpu.hostSteps.corners},
                                    {"row_culling", r.gpu.hostSteps.rowCulling},
                                    {"scans", r.gpu.hostSteps.scans},
                                    {"vertex_tile_lists", r.gpu.hostSteps.vertexTileLists},
                                    {"rows", r.gpu.hostSteps.rows},
                                    {"sources", r.gpu.hostSteps.sources},
                                    {"triangles", r.gpu.hostSteps.triangles}}}};
          if (!r.gpu.evaluator.empty()) {
            auto seconds = [](double v) { return v >= 0 ? nlohmann::json(v) : nlohmann::json(nullptr); };
            phases["evaluator"] = {{"traversal", r.gpu.evaluator}, {"generated_gradient", r.gpu.vertexGradient},
                                   {"uniform_vertex_program", r.gpu.vertexUniforms},
                                   {"vertex_tapes", r.gpu.vertexTapes},
                                   {"vertex_tape_windows", r.gpu.vertexTapeWindows},
                                   {"model_build_s", seconds(r.gpu.modelBuild)}, {"model_run_s", seconds(r.gpu.modelRun)}};
          }
        }
        // Each row stands alone (rows are often filtered or merged): the version, and where a
        // Vulkan device ran, which, as every --json report gives them.
        out.push_back(versionJson());
        if (!r.device.is_null()) out.back()["device"] = r.device;
        out.back().update({{"vk_phases", phases}, {"scene", r.scene}, {"backend", r.backend}, {"resolution", r.resolution},
                       {"threads", r.threads}, {"median_s", r.median}, {"min_s", r.min},
                       {"max_s", r.max}, {"first_s", r.first},
                       // vk start-up (kernel generation, glslang, pipelines, JIT) = first - steady.
                       {"steady_s", r.steady >= 0 ? nlohmann::json(r.steady) : nlohmann::json(nullptr)},
                       {"startup_s", r.steady >= 0 ? nlohmann::json(r.first - r.steady) : nlohmann::json(nullptr)},
                       {"background_build_wait_s", r.backgroundWait},
                       {"triangles", r.triangles}, {"vertices", r.vertices},
                       {"point_evaluations", r.evaluations},
                       {"fvept", r.triangles ? r.evaluations / double(r.triangles) : 0.0},
                       {"evaluations_per_s", r.median > 0 ? r.evaluations / r.median : 0.0},
                       {"output_s", r.outputSeconds}});
        if (!r.phases.empty()) {
          nlohmann::json phases = nlohmann::json::object();
          for (const auto& [name, seconds] : r.phases) phases[name] = seconds;
          out.back()["phases_s"] = phases;
        }
      }
      std::printf("%s\n", out.dump(2).c_str());
      return;
    }
    std::printf("%-28s %5s %-16s %7s %9s %9s %9s %9s %10s %7s %12s\n", "scene", "res", "backend", "threads",
                "median s", "min s", "max s", "first s", "triangles", "FVEPT", "evals/s");
    for (const Row& r : rows) {
      std::printf("%-28s %5d %-16s %7d %9.4f %9.4f %9.4f %9.4f %10zu %7.2f %12.4g\n", r.scene.c_str(),
                  r.resolution, r.backend.c_str(), r.threads, r.median, r.min, r.max, r.first, r.triangles,
                  r.triangles ? r.evaluations / double(r.triangles) : 0.0,
                  r.median > 0 ? r.evaluations / r.median : 0.0);
    }
  });
}

}  // namespace blobvk::app
