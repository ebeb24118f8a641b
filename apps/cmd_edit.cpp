// `blobvk edit SCENE EDITS.json -o out_%03d.ply|png`: applies a scripted sequence of edits
// (docs/editing.md) and writes the mesh, or a PNG of it, after each: frame 0 is the scene as
// loaded, frame k the mesh after k edits. The grid is chosen once, from the scene as loaded, and
// kept (an incremental re-mesh needs a fixed grid). Each edit re-meshes only the MPUs its region
// touches (cpu_simd/incremental_polygonizer.h) or, with --backend vk, the brick layers it reaches
// (vk/extract/incremental_extract.h); --check compares each result with a full re-mesh, byte for
// byte.
#include "backends.h"
#include "number_checks.h"
#include "cli_conventions.h"
#include "commands.h"
#include "edit_remesher.h"
#include "json_report.h"
#include "model.h"
#include "resolution_limit.h"

#include "blobvk/blobtree/edit_script.h"
#include "blobvk/mesh/io.h"

#ifdef BLOBVK_HAVE_VULKAN
#include "blobvk/vk/device/standalone.h"
#include "blobvk/vk/extract/polygonize.h"
#include "blobvk/vk/render/png_io.h"
#include "blobvk/vk/render/render_camera.h"
#include "blobvk/vk/render/render_mesh.h"
#endif

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <chrono>
#include <cstdio>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>

namespace blobvk::app {
namespace {

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

// "out_%03d.ply": one %d or %0Nd (N 1..9) and otherwise only %% may use '%'.
std::string framePath(const std::string& pattern, int frame) {
  std::string out;
  int conversions = 0;
  for (std::size_t i = 0; i < pattern.size(); ++i) {
    if (pattern[i] != '%') {
      out += pattern[i];
      continue;
    }
    if (i + 1 < pattern.size() && pattern[i + 1] == '%') {
      out += '%', ++i;
      continue;
    }
    std::size_t j = i + 1;
    int width = 0;
    if (j < pattern.size() && pattern[j] == '0' && j + 1 < pattern.size() && pattern[j + 1] >= '1' && pattern[j + 1] <= '9')
      width = pattern[j + 1] - '0', j += 2;
    if (j >= pattern.size() || pattern[j] != 'd')
      throw UsageError("-o: '" + pattern + "' may use '%' only as %d, %0Nd (N = 1..9) or %%");
    char buf[32];
    std::snprintf(buf, sizeof buf, "%0*d", width, frame);
    out += buf;
    ++conversions;
    i = j;
  }
  if (conversions != 1) throw UsageError("-o: '" + pattern + "' needs one %d or %0Nd for the frame number (e.g. out_%03d.ply)");
  return out;
}

}  // namespace

void addEditCommand(CLI::App& app) {
  struct Args {
    std::string scene, edits, out, size = "512x512", bounds;
    std::optional<float> cellSize;
    std::optional<int> resolution;
    int threads = 0, mpu = 0, brickCells = 0;
    std::string backend = "cpu", device, traversal = "auto";
    bool json = false, check = false, validation = false;
  };
  auto a = std::make_shared<Args>();
  auto* cmd = app.add_subcommand("edit", "Apply a scripted sequence of edits, re-meshing incrementally after each");
  cmd->add_option("scene", a->scene, "Scene file (.json, .blob, .scene)")->required();
  cmd->add_option("edits", a->edits, "Edit script (.json, see docs/editing.md)")->required();
  cmd->add_option("-o,--output", a->out, "Frames: a pattern with %d or %0Nd (.ply, .obj, .stl or .png), e.g. out_%03d.ply")->required();
  cmd->add_option("--bounds", a->bounds, kGridBoundsHelp)->check(gridBounds());
  auto* cs = cmd->add_option("--cell-size", a->cellSize, "Grid cell size (world units)")->check(cellSize());
  cmd->add_option("--resolution", a->resolution, "Cells along the longest side of the model as loaded")
      ->check(resolutionRange())
      ->excludes(cs);
  cmd->add_option("--threads", a->threads, "CPU threads (0 = all cores)")->check(CLI::Range(0, 1024));
  cmd->add_option("--mpu", a->mpu, "cpu: cells per MPU side (0 = default)")->check(mpuCells());
  cmd->add_option("--backend", a->backend, "cpu (default) or vk")->check(CLI::IsMember({"cpu", "vk"}));
  cmd->add_option("--device", a->device, "vk: Vulkan device (name substring or index)")->check(nonEmptyText());
  cmd->add_option("--traversal", a->traversal,
                  "vk: auto (default: the cost model picks per re-run, counting a specialised kernel's build per "
                  "edit), specialised, stackless or stack")
      ->check(CLI::IsMember(traversalNames()));
  cmd->add_option("--brick-cells", a->brickCells, "vk: cells per brick edge, 2 to 16, a power of two (0 = default)")
      ->check(CLI::IsMember({0, 2, 4, 8, 16}));
  cmd->add_flag("--validation", a->validation, "vk: enable the Vulkan validation layer");
  cmd->add_option("--size", a->size, "PNG frames: image size WxH (default 512x512)");
  cmd->add_flag("--check", a->check, "Also re-mesh the whole grid after each edit and fail unless the bytes are equal");
  cmd->add_flag("--json", a->json, "Print per-edit timings as JSON");
  cmd->callback([a, cmd] {
    const std::string first = framePath(a->out, 0);
    const std::string dot = first.substr(std::min(first.size(), first.rfind('.') == std::string::npos ? first.size() : first.rfind('.')));
    checkOutputFile(first, {".ply", ".obj", ".stl", ".png"}, false, "a mesh or an image");
    std::string format = dot.empty() ? "" : dot.substr(1);
    for (char& c : format) c = char(std::tolower(static_cast<unsigned char>(c)));
    const bool png = format == "png";
    if (!png && cmd->count("--size")) throw UsageError("--size is the size of PNG frames; these frames are ." + format + " meshes");
    unsigned width = 0, height = 0;
    if (png) {
      char x = 0;
      std::stringstream ss(a->size);
      if (!(ss >> width >> x >> height) || x != 'x' || width < 1 || height < 1 || width > unsigned(kMaxImageSide) ||
          height > unsigned(kMaxImageSide) || !ss.eof())
        throw UsageError("--size: '" + a->size + "' is not WxH with 1 <= W, H <= " + std::to_string(kMaxImageSide));
#ifndef BLOBVK_HAVE_VULKAN
      throw std::runtime_error("this blobvk was built without Vulkan (BLOBVK_WITH_VULKAN=OFF): write .ply frames instead");
#endif
    }
    const bool vkBackend = a->backend == "vk";
#ifndef BLOBVK_HAVE_VULKAN
    if (vkBackend) throw std::runtime_error("--backend vk: this blobvk was built without Vulkan (BLOBVK_WITH_VULKAN=OFF)");
#endif
    if (!vkBackend && (!a->device.empty() || a->traversal != "auto" || a->brickCells || a->validation))
      throw UsageError("--device, --traversal, --brick-cells and --validation are for --backend vk");
    if (vkBackend && (a->threads || a->mpu)) throw UsageError("--threads and --mpu are for --backend cpu");

    Model model = loadModel(a->scene);
    applyGridBounds(model, a->bounds);
    const blobtree::EditScript script = blobtree::readEditScript(a->edits);
    checkOutputFile(framePath(a->out, int(script.edits.size())), {".ply", ".obj", ".stl", ".png"}, false, "a mesh or an image");
    const blobtree::GridSpec grid = gridFor(model, a->cellSize, a->resolution);
    blobtree::EditableTree tree(model.scene.root);
    std::unique_ptr<EditRemesher> inc;
    if (!vkBackend) {
      cpu::MpuOptions options;
      options.threads = a->threads;
      if (a->mpu > 0) options.mpuCells = a->mpu;
      inc = makeCpuRemesher(grid, options);
    }

#ifdef BLOBVK_HAVE_VULKAN
    // One device for the vk backend and the PNG frames.
    std::unique_ptr<vk::StandaloneContext> ctx;
    if (png || vkBackend) {
      vk::StandaloneOptions contextOptions;
      contextOptions.device = a->device;
      contextOptions.validation = a->validation;
      ctx = std::make_unique<vk::StandaloneContext>(contextOptions);
    }
    if (vkBackend) {
      vk::GpuPolygonizeOptions options;
      options.traversal = traversalFromName(a->traversal);
      if (a->brickCells > 0) options.brickCells = std::uint32_t(a->brickCells);
      inc = makeVkRemesher(ctx->device(), grid, options);
    }
    std::unique_ptr<vk::MeshRenderer> renderer;
    std::optional<vk::Camera> camera;
    if (png) {
      renderer = std::make_unique<vk::MeshRenderer>(ctx->device(), width, height);
      // One camera for every frame, from the model as loaded, so frames compare.
      camera = vk::resolveCamera(viewBounds(model), model.scene.camera, {}, float(width) / float(height));
    }
#endif
    const auto write = [&](const mesh::TriMesh& m, int frame) {
      const std::string path = framePath(a->out, frame);
#ifdef BLOBVK_HAVE_VULKAN
      if (png) {
        writeOutput(path, vk::encodePng(renderer->render(m, *camera)));
        return path;
      }
#endif
      writeOutput(path, mesh::encodeMesh(m, format));
      return path;
    };

    nlohmann::json report = versionJson();
    report["scene"] = a->scene;
    report["edits_file"] = a->edits;
    report["backend"] = a->backend;
#ifdef BLOBVK_HAVE_VULKAN
    if (ctx) report["device"] = deviceJson(ctx->host().physicalDevice);  // what ran the vk backend and drew the frames
#endif
    report["grid"] = {{"cells", {grid.cells.x, grid.cells.y, grid.cells.z}}, {"cell_size", grid.cellSize},
                      {"origin", {grid.origin.x, grid.origin.y, grid.origin.z}}};
    auto t0 = Clock::now();
    const mesh::TriMesh& initial = inc->reset(tree.program());
    const double initialMs = msSince(t0);
    const std::string initialPath = write(initial, 0);
    report["initial"] = {{"ms", initialMs}, {"triangles", initial.triangleCount()}, {"output", initialPath}};
    const bool talk = !a->json && !quiet();
    if (talk)
      std::printf("%s: %d x %d x %d cells of %.4g, full mesh %.1f ms, %zu triangles\n", initialPath.c_str(),
                  grid.cells.x, grid.cells.y, grid.cells.z, grid.cellSize, initialMs, initial.triangleCount());
    nlohmann::json rows = nlohmann::json::array();
    for (std::size_t i = 0; i < script.edits.size(); ++i) {
      t0 = Clock::now();
      const blobtree::Region region = blobtree::applyScriptEdit(script, i, tree);
      const double applyMs = msSince(t0);
      RemeshReport st;
      const mesh::TriMesh& m = inc->update(tree.program(), region, st);
      if (a->check && !(m == inc->full(tree.program())))
        throw std::runtime_error(a->edits + ": /edits/" + std::to_string(i) + ": the incremental mesh differs from a full re-mesh");
      const std::string path = write(m, int(i) + 1);
      nlohmann::json row = {{"index", i},
                            {"edit", blobtree::describeEdit(script, i)},
                            {"apply_ms", applyMs},
                            {"remesh_ms", st.ms},
                            {"full_remesh", st.full},
                            {"vertices", m.vertexCount()},
                            {"triangles", m.triangleCount()},
                            {"output", path}};
      if (region.empty()) row["region"] = nullptr;
      else if (region.everything()) row["region"] = "everything";
      else row["region"] = {{"lo", {region.lo.x, region.lo.y, region.lo.z}}, {"hi", {region.hi.x, region.hi.y, region.hi.z}}};
      row.update(st.fields);
      if (a->check) row["checked"] = true;
      if (talk)
        std::printf("edit %zu/%zu %s: apply %.2f ms, re-mesh %.2f ms (%s%s), %zu triangles -> %s\n", i + 1,
                    script.edits.size(), blobtree::describeEdit(script, i).c_str(), applyMs, st.ms, st.note.c_str(),
                    st.full ? ", whole grid" : "", m.triangleCount(), path.c_str());
      rows.push_back(std::move(row));
    }
    report["edits"] = std::move(rows);
    if (a->json) std::printf("%s\n", report.dump(2).c_str());
#ifdef BLOBVK_HAVE_VULKAN
    if (ctx && ctx->validationMessages() > 0)
      throw std::runtime_error(std::to_string(ctx->validationMessages()) + " Vulkan validation message(s)");
#endif
  });
}

}  // namespace blobvk::app
