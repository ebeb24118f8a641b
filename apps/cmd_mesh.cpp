// `blobvk mesh SCENE -o out.ply`: polygonize a scene and write the mesh ("-o -" streams a binary
// PLY, or --format's, to standard output). The output is checked before any work. .gltf/.glb
// write glTF 2.0 (engine-ready: vertex-cache/fetch ordered unless --no-optimize); --simplify
// reduces the mesh with meshoptimizer and the check line says whether it stayed closed.
#include "backends.h"
#include "number_checks.h"
#include "cli_conventions.h"
#include "commands.h"
#include "json_report.h"
#include "mesh_mpi.h"
#include "mesh_streaming.h"
#include "model.h"
#include "progress.h"
#include "resolution_limit.h"
#include "resource_limits.h"

#include "blobvk/cpu_simd/sharp_features.h"
#include "blobvk/mesh/checks.h"
#include "blobvk/mesh/engine/gltf.h"
#include "blobvk/mesh/engine/simplify.h"
#include "blobvk/mesh/engine/vertex_order.h"
#include "blobvk/mesh/io.h"

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <cctype>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>

namespace blobvk::app {

namespace {
// The vk backend's figures in `mesh --json` (in memory and streamed alike).
nlohmann::json gpuJson(const PolygonizeStats::Phases& gpu) {
  return {{"batches", gpu.batches}, {"active_bricks", gpu.activeBricks}, {"device_bytes", gpu.deviceBytes},
          {"devices", gpu.devices}, {"evaluator", gpu.evaluator}, {"generated_gradient", gpu.vertexGradient},
          {"uniform_vertex_program", gpu.vertexUniforms}, {"vertex_tapes", gpu.vertexTapes}, {"vertex_tape_windows", gpu.vertexTapeWindows}, {"host_classification", gpu.hostClassification},
          {"brick_cells", gpu.brickCells}, {"field_tiles", gpu.fieldTiles}, {"vertex_tiles", gpu.vertexTiles},
          {"tape_instructions", gpu.tapeInstructions},
          {"generated_classification", gpu.generatedClassification}, {"classify_tiles", gpu.classifyTiles}};
}

}  // namespace

void addMeshCommand(CLI::App& app) {
  struct Args {
    std::string scene, out, format, bounds;
    std::optional<float> cellSize;
    std::optional<int> resolution;
    PolygonizeSettings settings;
    bool ascii = false, json = false, stream = false;
    std::string simplify;  // parsed by mesh::parseSimplifyTarget
    bool features = false;
    float featureAngle = 30.0f;
    bool optimize = false, noOptimize = false;  // neither: on for glTF, off otherwise
    std::string maxMemory;
    Limits limits;
  };
  auto a = std::make_shared<Args>();
  auto* cmd = app.add_subcommand("mesh", "Polygonize a scene into a mesh (.ply, .obj, .stl, .gltf, .glb)");
  cmd->footer(
      "Under mpirun -n N (cpu backend, streamed): the layers are shared over the ranks, each rank writes its own "
      "layers into the one-process file. The shares are equal; when rank 0 checks the mesh it computes less "
      "(0.4 of the layers with 2 ranks, 0.2 with 3, none from 6); BLOBVK_MPI_ROOT_SHARE=0..1 sets its share.");
  cmd->add_option("scene", a->scene, "Scene file (.json, .blob, .scene)")->required();
  cmd->add_option("-o,--output", a->out, "Output mesh (.ply, .obj, .stl, .gltf, .glb; - for standard output)")->required();
  cmd->add_option("--format", a->format, "Format for -o - or an output without an extension such as /dev/null (ply, obj, stl, gltf, glb; default ply)")
      ->check(CLI::IsMember(std::vector<std::string>{"ply", "obj", "stl", "gltf", "glb"}));
  cmd->add_option("--bounds", a->bounds, kGridBoundsHelp)->check(gridBounds());
  auto* cs = cmd->add_option("--cell-size", a->cellSize, "Grid cell size (world units)")
                 ->check(cellSize());
  cmd->add_option("--resolution", a->resolution, "Cells along the longest side of the model")
      ->check(meshResolutionRange())
      ->excludes(cs);
  cmd->add_option("--backend", a->settings.backend, "cpu (default), reference or vk")->check(CLI::IsMember(allBackendNames()));
  cmd->add_option("--threads", a->settings.threads, "CPU threads (0 = all cores)")
      ->check(CLI::Range(0, 1024));
  cmd->add_option("--mpu", a->settings.mpuSize, "Cells per MPU side (cpu backend; 0 = default)")
      ->check(mpuCells());
  cmd->add_option("--refine", a->settings.refineSteps, "Root refinement steps per vertex")
      ->check(CLI::Range(0, 16));
  auto* one = cmd->add_option("--device", a->settings.device, "Vulkan device (name substring or index)")->check(nonEmptyText());
  cmd->add_option("--devices", a->settings.devices,
                  "vk: several Vulkan devices sharing the bricks, same bytes as one: all, or indices/names "
                  "(0,1; a device named twice is opened twice)")
      ->check(nonEmptyText())
      ->excludes(one);
  cmd->add_flag("--cpu-worker", a->settings.cpuWorker,
                "vk: the CPU polygonizer takes bricks beside the Vulkan devices (on --threads threads, default 1), same bytes");
  cmd->add_flag("--validation", a->settings.validation, "Enable the Vulkan validation layer");
  cmd->add_option("--traversal", a->settings.traversal, "vk: auto (default: the cost model picks per job), specialised, stackless or stack")
      ->check(CLI::IsMember(traversalNames()));
  cmd->add_option("--brick-cells", a->settings.brickCells,
                  "vk: cells per brick edge of the sparse extraction, 2 to 16, a power of two (0 = default: 16, halved "
                  "while a pair of brick layers outgrows a storage buffer); the mesh does not depend on it")
      ->check(CLI::IsMember({0, 2, 4, 8, 16}));
  cmd->add_option("--field-tiles", a->settings.fieldTiles,
                  "vk specialised: most grid tiles with their own pruned field kernel (1 = one kernel; default 8, "
                  "up to 16 for repeated jobs, and up to 128 where a long program's tiles would otherwise loop, where "
                  "the cost model says they pay; a given N caps them all)")
      ->check(CLI::Range(1, 256));
  // The dense pipeline's flag (bench --dense --tiled-vertices), which once switched mesh to that
  // pipeline unasked: kept out of the help, refused with the sparse extraction's name for it.
  cmd->add_flag("--tiled-vertices", a->settings.tiledVertices)->group("");
  cmd->add_flag("--vertex-tiles", a->settings.vertexTiles,
                "vk sparse, specialised: run the vertex pass per field tile with pruned kernels (slower to start; "
                "the same mesh)");
  cmd->add_flag("--brick-tapes", a->settings.brickTapes,
                "vk sparse: the field pass interprets, per brick, the program pruned to the brick (the same mesh; "
                "auto takes it on lavapipe for long looped programs where it pays)");
  cmd->add_flag("--no-row-culling{false}", a->settings.rowCulling,
                "vk sparse on lavapipe: evaluate every row of points of an active brick, not only those the CPU "
                "backend's bound leaves (the same mesh)");
  cmd->add_flag("--device-passes{false}", a->settings.hostPasses,
                "vk sparse on lavapipe: run the bookkeeping passes (classification, scans, row counts, sources, "
                "triangles) as kernels on the device, not on the host (the same mesh)");
  cmd->add_option("--max-memory", a->maxMemory,
                  "Memory budget (e.g. 2G; default: available): a cpu or vk job whose mesh may not fit is streamed to the file layer by layer")
      ->check(nonEmptyText());
  cmd->add_flag("--stream", a->stream,
                "Always stream: write the mesh as it is made (cpu: layer by layer of MPUs; vk: batch by batch of brick layers), holding a few layers");
  cmd->add_option("--max-triangles", a->limits.maxTriangles, "Refuse meshes with more triangles (at least 1)")
      ->check(CLI::Range(std::uint64_t(1), std::uint64_t(1) << 62));
  auto* features = cmd->add_flag("--features", a->features,
                "Sharp features: a vertex on the crease or corner in each cell whose normals disagree (extended marching cubes)");
  cmd->add_option("--feature-angle", a->featureAngle, "--features: degrees between normals that mark a crease (default 30)")
      ->check(finiteRange(1.0, 179.0))
      ->needs(features);
  cmd->add_option("--simplify", a->simplify,
                  "Simplify with meshoptimizer: RATIO of triangles kept (0.25) or ERROR% of the extent (0.5%); "
                  "a closed mesh stays closed")
      ->check(nonEmptyText());
  auto* opt = cmd->add_flag("--optimize", a->optimize,
                            "Order triangles and vertices for the GPU's vertex cache and fetch (default for .gltf/.glb)");
  cmd->add_flag("--no-optimize", a->noOptimize, "Keep the polygonizer's grid-edge vertex order in .gltf/.glb")->excludes(opt);
  cmd->add_flag("--ascii", a->ascii, "Write ASCII PLY instead of binary");
  cmd->add_flag("--json", a->json, "Print the summary as JSON (with the blobvk version and, for vk, the device)");
  cmd->callback([a, cmd] {
    refuseOptionsNoBackendUses(*cmd, {a->settings.backend});
    // Everything about the output is checked before the (possibly long) polygonization.
    // A file's format is its extension; --format names it for standard output and for a name
    // without one (a device or a pipe: /dev/null, /dev/fd/3).
    const bool named = !a->format.empty() && a->out != "-";
    if (named && !std::filesystem::path(a->out).extension().empty())
      throw UsageError("--format is for -o - or a name without an extension (a file's format is its extension)");
    const bool toStdout = named ? checkOutputFile(a->out, {""}, false, "a mesh")
                                : checkOutputFile(a->out, {".ply", ".obj", ".stl", ".gltf", ".glb"}, true, "a mesh");
    if (toStdout && a->json) throw UsageError("--json and -o - both want standard output; write the mesh to a file");
    std::string format = toStdout || named ? (a->format.empty() ? "ply" : a->format) : a->out.substr(a->out.rfind('.') + 1);
    for (char& c : format) c = char(std::tolower(static_cast<unsigned char>(c)));
    if (a->ascii && format != "ply") throw UsageError("--ascii is for PLY output");
    if (a->noOptimize && format != "gltf" && format != "glb")
      throw UsageError("--no-optimize is for .gltf/.glb (other formats keep the polygonizer's order unless --optimize)");
    if (a->settings.tiledVertices)
      throw UsageError("--tiled-vertices is the dense pipeline's (blobvk bench --dense); the sparse extraction's vertex "
                       "pass per tile is --vertex-tiles");
    checkDeviceList(a->settings);
    if (!a->maxMemory.empty()) {
      try {
        a->limits.maxMemoryBytes = parseByteSize(a->maxMemory);
      } catch (const std::invalid_argument& e) {
        throw UsageError(std::string("--max-memory: ") + e.what());
      }
    }
    const bool gltf = format == "gltf" || format == "glb";
    std::optional<mesh::SimplifyTarget> simplifyTarget;
    if (!a->simplify.empty()) {
      try {
        simplifyTarget = mesh::parseSimplifyTarget(a->simplify);
      } catch (const std::invalid_argument& e) {
        throw UsageError(e.what());
      }
    }
    const bool optimize = a->optimize || (gltf && !a->noOptimize);
    // --stream asked for what cannot stream: a usage error, found before any work (a job that
    // streams because it is over the --max-memory budget is told so where it is decided).
    if (a->stream && gltf) throw UsageError("--stream writes .ply, .obj or .stl; ." + format + " needs the whole mesh in memory");
    if (a->stream && a->settings.backend == "reference")
      throw UsageError("--stream runs on the cpu and vk backends, not reference");

    Model model = loadModel(a->scene);
    applyGridBounds(model, a->bounds);
    const blobtree::GridSpec grid = gridFor(model, a->cellSize, a->resolution);
    const std::string gridText =
        std::to_string(grid.cells.x) + " x " + std::to_string(grid.cells.y) + " x " + std::to_string(grid.cells.z);
    // --max-memory is a budget: a cpu or vk job whose whole mesh may not fit is streamed instead
    // (vk with one device: several devices join their batches in memory).
    const std::uint64_t budget = a->limits.maxMemoryBytes ? a->limits.maxMemoryBytes : availableMemoryBytes();
    const std::uint64_t inMemory = estimatePolygonizeBytes(grid, a->settings.backend);
    const bool streams = a->settings.backend == "cpu" || (a->settings.backend == "vk" && a->settings.devices.empty() && !a->settings.cpuWorker);
    // Streaming only where it needs less: on a small grid its layer buffers can outweigh the
    // whole mesh, and a job refused for the streamed need could have run in memory.
    const std::uint64_t streamedNeed = estimateStreamedBytes(grid, a->settings.mpuSize);
    const bool stream =
        a->stream || launchedByMpi() || (streams && budget != 0 && inMemory > budget && streamedNeed < inMemory);
    if (stream && (simplifyTarget || a->optimize || a->features)) {
      throw UsageError("--features, --simplify and --optimize need the whole mesh in memory; they cannot be combined with streaming"
                       " (--stream, an MPI launch, or a mesh over the --max-memory budget)");
    }
    if (stream) {
      checkMemory(streamedNeed, a->limits, gridPlace(model, a->cellSize, a->resolution) + "streaming a " + gridText + " grid");
      const bool check = !toStdout && !(quiet() && !a->json);
      const StreamedMeshResult r = meshStreamed(model.program, grid, a->settings, a->out, format, a->ascii, check, a->limits);
      if (!r.worker && r.triangles == 0) warnEmptyMesh("blobvk", grid.cells.x, grid.cells.y, grid.cells.z);
      if (r.worker || !check) return;
      if (a->json) {
        nlohmann::json out = versionJson();
        out["output"] = a->out;
        out["scene"] = a->scene;
        out["grid"] = {{"cells", {grid.cells.x, grid.cells.y, grid.cells.z}}, {"cell_size", grid.cellSize},
                       {"origin", {grid.origin.x, grid.origin.y, grid.origin.z}}};
        out["backend"] = a->settings.backend;
        if (r.gpu) {
          out["device"] = backendDeviceJson(a->settings);
          out["gpu"] = gpuJson(*r.gpu);
        }
        out["streamed"] = true;
        out["ranks"] = r.ranks;
        out["seconds"] = r.seconds;
        out["point_evaluations"] = r.pointEvaluations;
        out["vertices"] = r.vertices;
        out["triangles"] = r.triangles;
        out["bytes"] = r.bytes;
        out["check"] = {{"watertight", r.report->watertight()}, {"volume", r.report->volume}, {"summary", r.report->summary()}};
        std::printf("%s\n", out.dump(2).c_str());
        return;
      }
      const std::string how = r.ranks > 1 ? "streamed, " + std::to_string(r.ranks) + " MPI ranks" : "streamed";
      std::printf("%s: %s cells of %.4g, backend %s (%s), %.3f s\n", a->out.c_str(), gridText.c_str(),
                  grid.cellSize, a->settings.backend.c_str(), how.c_str(), r.seconds);
      std::printf("%s\n", r.report->summary().c_str());
      return;
    }
    checkMemory(inMemory, a->limits, gridPlace(model, a->cellSize, a->resolution) + "a " + gridText + " grid");

    // The cpu backend reports per group of MPUs; the others have no count: one line per phase.
    std::optional<Progress> progress;
    if (a->settings.backend == "cpu") {
      progress.emplace("mesh", 0);
      a->settings.progress = [&progress](std::size_t done, std::size_t total) { progress->update(long(done), long(total)); };
    } else {
      Progress::note("mesh", "polygonizing a " + gridText + " grid on the " + a->settings.backend + " backend");
      a->settings.phaseNote = [](const std::string& text) { Progress::note("mesh", text); };
      a->settings.classifyProgress = restartingProgress("classify");
    }
    PolygonizeStats stats;
    mesh::TriMesh mesh = polygonize(model.program, grid, a->settings, &stats);
    a->settings.progress = nullptr;  // it refers to `progress`, which ends here
    progress.reset();
    checkTriangles(mesh.triangleCount(), a->limits);
    checkFiniteVertices(mesh.positions);
    if (mesh.triangleCount() == 0) warnEmptyMesh("blobvk", grid.cells.x, grid.cells.y, grid.cells.z);
    std::optional<cpu::FeatureReport> featured;
    if (a->features) {
      cpu::FeatureOptions options;
      options.creaseDegrees = a->featureAngle;
      cpu::placeSharpFeatures(mesh, grid, options, &featured.emplace());
    }
    std::optional<mesh::SimplifyReport> simplified;
    if (simplifyTarget) mesh = mesh::simplifyMesh(mesh, *simplifyTarget, &simplified.emplace());
    std::optional<mesh::VertexOrderReport> ordered;
    if (optimize) ordered = mesh::optimizeVertexOrder(mesh);
    const std::string bytes = a->ascii ? mesh::encodePly(mesh, false)
                              : gltf   ? mesh::encodeGltf(mesh, format == "glb")
                                       : mesh::encodeMesh(mesh, format);
    writeOutput(a->out, bytes);
    if (toStdout || (quiet() && !a->json)) return;
    const mesh::MeshReport report = mesh::checkMesh(mesh);
    if (a->json) {
      nlohmann::json out = versionJson();
      out["output"] = a->out;
      out["scene"] = a->scene;
      out["grid"] = {{"cells", {grid.cells.x, grid.cells.y, grid.cells.z}}, {"cell_size", grid.cellSize},
                     {"origin", {grid.origin.x, grid.origin.y, grid.origin.z}}};
      out["backend"] = a->settings.backend;
      if (a->settings.backend == "vk") out[a->settings.devices.empty() ? "device" : "devices"] = backendDeviceJson(a->settings);
      out["seconds"] = stats.seconds;
      out["point_evaluations"] = stats.pointEvaluations;
      if (a->settings.backend == "vk")
        out["gpu"] = gpuJson(stats.gpu);
      out["vertices"] = mesh.vertexCount();
      out["triangles"] = mesh.triangleCount();
      out["bytes"] = bytes.size();
      out["check"] = {{"watertight", report.watertight()}, {"volume", report.volume}, {"summary", report.summary()}};
      if (featured)
        out["features"] = {{"feature_cells", featured->featureCells}, {"feature_vertices", featured->featureVertices},
                           {"kept", featured->rejected}, {"kept_not_a_disc", featured->notADisc},
                           {"kept_folds", featured->folds}, {"flips", featured->flips}};
      if (simplified)
        out["simplify"] = {{"triangles_before", simplified->trianglesBefore}, {"triangles_after", simplified->trianglesAfter},
                           {"error", simplified->error}, {"watertight_before", simplified->watertightBefore},
                           {"watertight_after", simplified->watertightAfter}, {"kept_input", simplified->keptInput},
                           {"backed_off", simplified->backedOff}, {"triangles_first_try", simplified->trianglesFirstTry},
                           {"attempts", simplified->attempts}};
      if (ordered)
        out["vertex_order"] = {{"acmr_before", ordered->acmrBefore}, {"acmr_after", ordered->acmrAfter},
                               {"overfetch_before", ordered->overfetchBefore}, {"overfetch_after", ordered->overfetchAfter}};
      std::printf("%s\n", out.dump(2).c_str());
      return;
    }
    std::printf("%s: %s cells of %.4g, backend %s, %.3f s\n", a->out.c_str(), gridText.c_str(), grid.cellSize,
                a->settings.backend.c_str(), stats.seconds);
    // One check line: the mesh's topology, then what simplification and reordering did to it.
    std::string check = report.summary();
    if (featured)
      check += "; features: " + std::to_string(featured->featureVertices) + " vertices, " + std::to_string(featured->flips) +
               " flips (" + std::to_string(featured->rejected) + " cells kept)";
    if (simplified) check += "; " + simplified->summary();
    if (ordered) check += "; " + ordered->summary();
    std::printf("%s\n", check.c_str());
  });
}

}  // namespace blobvk::app
