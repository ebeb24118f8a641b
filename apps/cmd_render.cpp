// `blobvk render SCENE -o out.png`: headless rendering with the offscreen rasterizer (mesh mode,
// the mesh from any polygonizer backend; the vk backend draws from the GPU without a read-back)
// or the compute ray-caster (raycast mode). --turntable N writes N frames around the target.
#include "number_checks.h"
#include "render_command.h"

#include "backends.h"
#include "cli_conventions.h"
#include "commands.h"
#include "model.h"
#include "progress.h"
#include "resolution_limit.h"

#include "blobvk/blobtree/decimal.h"
#include "blobvk/blobtree/scene_limits.h"

#include <CLI/CLI.hpp>

#ifdef BLOBVK_HAVE_VULKAN
#include "blobvk/vk/render/png_io.h"
#include "blobvk/vk/render/raycast.h"
#include "blobvk/vk/render/render_gpu_mesh.h"
#include "blobvk/vk/render/render_mesh.h"
#include "blobvk/vk/device/error.h"
#include "blobvk/vk/device/standalone.h"
#endif

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace blobvk::app {
namespace {

std::vector<float> parseNumbers(const std::string& text, const char* what, std::size_t minCount,
                                                 std::size_t maxCount) {
  std::vector<float> out;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    // Read as a double (blobtree::readDecimal, as the legacy reader), so that a finite number
    // beyond float's range (1e300) is reported as out of range, not as not finite; one below
    // double's reads as zero. Spaces around an item are allowed.
    const std::size_t from = item.find_first_not_of(" \t"), to = item.find_last_not_of(" \t");
    const std::optional<blobtree::Decimal> d =
        from == std::string::npos ? std::nullopt : blobtree::readDecimal(std::string_view(item).substr(from, to - from + 1));
    if (!d || std::isnan(d->value) || (!d->beyondDouble && std::isinf(d->value)))
      throw CLI::ValidationError(what, "'" + text + "' is not a comma-separated list of finite numbers");
    const double value = d->value;
    // The scene format's range for any number (blobtree/scene_limits.h): a camera 1e30 away sees nothing.
    if (!(std::abs(value) <= blobtree::limits::kMaxAbsValue))
      throw CLI::ValidationError(what, "'" + item + "' is out of range (|x| must be <= 1e6)");
    out.push_back(float(value));
  }
  if (out.size() < minCount || out.size() > maxCount) {
    throw CLI::ValidationError(what, "'" + text + "' needs " + std::to_string(minCount) +
                                         (minCount == maxCount ? "" : " to " + std::to_string(maxCount)) +
                                         " numbers");
  }
  return out;
}

// out.png -> out_007.png for turntable frames.
std::string framePath(const std::string& out, int frame, int frames) {
  if (frames <= 1) return out;
  const auto dot = out.find_last_of('.');
  const std::string stem = dot == std::string::npos ? out : out.substr(0, dot);
  const std::string ext = dot == std::string::npos ? ".png" : out.substr(dot);
  char index[16];
  std::snprintf(index, sizeof(index), "_%03d", frame);
  return stem + index + ext;
}

}  // namespace

void addRenderCommand(CLI::App& app) {
  struct Args {
    std::string scene, out, size = "512x512", camera, eye, target, mode = "mesh", bounds;
    std::optional<float> cellSize, fov;
    std::optional<int> resolution;
    PolygonizeSettings settings;
    int turntable = 1;
    int samples = 4;
    bool wireframe = false;
  };
  auto a = std::make_shared<Args>();
  auto* cmd = app.add_subcommand("render", "Render a scene to PNG (raster of its mesh, or ray-cast field)");
  cmd->add_option("scene", a->scene, "Scene file (.json, .blob, .scene)")->required();
  cmd->add_option("-o,--output", a->out, "Output .png (- for standard output; turntable: out_000.png, out_001.png, ...)")->required();
  cmd->add_option("--size", a->size, "Image size WxH (default 512x512)");
  auto* cam = cmd->add_option("--camera", a->camera, "Orbit: azimuth,elevation[,distance] in degrees / world units")->check(nonEmptyText());
  auto* eye = cmd->add_option("--eye", a->eye, "Camera position x,y,z")->check(nonEmptyText())->excludes(cam);
  cmd->add_option("--target", a->target, "Point looked at x,y,z (default: the scene's, else the centre)")->check(nonEmptyText());
  cmd->add_option("--fov", a->fov, "Vertical field of view in degrees")->check(finiteRange(1.0, 170.0));
  cmd->add_option("--mode", a->mode, "mesh (rasterize the polygonized mesh, default) or raycast")
      ->check(CLI::IsMember({"mesh", "raycast"}));
  cmd->add_option("--backend", a->settings.backend, "Polygonizer for mesh mode: cpu (default), reference, vk")
      ->check(CLI::IsMember(allBackendNames()));
  cmd->add_option("--bounds", a->bounds, kGridBoundsHelp)->check(gridBounds());
  auto* cs = cmd->add_option("--cell-size", a->cellSize, "Grid cell size (mesh mode)")->check(cellSize());
  cmd->add_option("--resolution", a->resolution, "Cells along the longest side (mesh mode)")
      ->check(resolutionRange())
      ->excludes(cs);
  cmd->add_option("--turntable", a->turntable, "Frames around the vertical axis (default 1)")
      ->check(CLI::Range(1, 3600));
  cmd->add_option("--samples", a->samples, "MSAA samples for mesh mode (1, 2, 4, 8; default 4)")
      ->check(CLI::IsMember({1, 2, 4, 8}));
  cmd->add_flag("--wireframe", a->wireframe,
                "Overlay the mesh edges (mesh mode; with --backend vk the mesh is read back to build the edge list)");
  cmd->add_option("--device", a->settings.device, "Vulkan device (name substring or index)")->check(nonEmptyText());
  cmd->add_flag("--validation", a->settings.validation, "Enable the Vulkan validation layer");
  (void)eye;
  cmd->callback([a, cmd] {
    // The command line is checked first, whatever this build can do: a usage error is one.
    unsigned width = 0, height = 0;
    char x = 0;
    std::stringstream ss(a->size);
    if (!(ss >> width >> x >> height) || x != 'x' || width < 1 || height < 1 || width > unsigned(kMaxImageSide) ||
        height > unsigned(kMaxImageSide) || !ss.eof()) {
      throw UsageError("--size: '" + a->size + "' is not WxH with 1 <= W, H <= " + std::to_string(kMaxImageSide));
    }
    if (a->mode != "mesh" && a->wireframe) throw UsageError("--wireframe draws mesh edges: it needs --mode mesh");
    // The ray-caster meshes nothing and samples each pixel once: mesh mode's options would be
    // ignored without a word.
    if (a->mode != "mesh")
      for (const char* option : {"--samples", "--backend", "--cell-size", "--resolution"})
        if (cmd->count(option)) throw UsageError(std::string(option) + " is for --mode mesh (the ray-caster polygonizes nothing)");
    // The format and the place are checked before any work: PNG only (PNG streams, so "-" works
    // for a single frame).
    if (a->out == "-" && a->turntable > 1)
      throw UsageError("--turntable writes a file per frame (NAME_000.png, ...): give a file name, not '-'");
    const bool toStdout = checkOutputFile(a->out, {".png"}, a->turntable == 1, "an image (blobvk writes PNG)");
    if (a->turntable > 1) {
      for (int frame : {0, a->turntable - 1}) checkOutputFile(framePath(a->out, frame, a->turntable), {".png"}, false, "an image");
    }
    // The camera's numbers are usage errors, found before anything else is (Vulkan or not).
    const std::vector<float> orbit = a->camera.empty() ? std::vector<float>{} : parseNumbers(a->camera, "--camera", 2, 3);
    if (!orbit.empty() && std::abs(orbit[1]) > 90.0f) throw CLI::ValidationError("--camera", "elevation must be within [-90, 90] degrees");
    if (orbit.size() == 3 && !(orbit[2] > 0.0f)) throw CLI::ValidationError("--camera", "distance must be > 0");
    const std::vector<float> eye = a->eye.empty() ? std::vector<float>{} : parseNumbers(a->eye, "--eye", 3, 3);
    const std::vector<float> target = a->target.empty() ? std::vector<float>{} : parseNumbers(a->target, "--target", 3, 3);
#ifndef BLOBVK_HAVE_VULKAN
    (void)toStdout;
    throw std::runtime_error("this blobvk was built without Vulkan (BLOBVK_WITH_VULKAN=OFF): no renderer");
#else
    Model model = loadModel(a->scene);
    applyGridBounds(model, a->bounds);
    vk::CameraRequest request;
    if (!orbit.empty()) {
      request.azimuthDeg = orbit[0];
      request.elevationDeg = orbit[1];
      if (orbit.size() == 3) request.distance = orbit[2];
    }
    if (!eye.empty()) request.eye = glm::vec3(eye[0], eye[1], eye[2]);
    if (!target.empty()) request.target = glm::vec3(target[0], target[1], target[2]);
    request.fovYDeg = a->fov;
    const vk::Camera camera =
        vk::resolveCamera(viewBounds(model), model.scene.camera, request, float(width) / float(height));

    vk::StandaloneOptions options;
    options.device = a->settings.device;
    options.validation = a->settings.validation;
    vk::StandaloneContext ctx(options);
    auto& device = ctx.device();

    std::unique_ptr<vk::MeshRenderer> renderer;
    std::unique_ptr<vk::Raycaster> raycaster;
    vk::UploadedMesh uploaded;
    vk::GpuMesh gpuMesh;
    vk::MeshView view;
    std::string what;
    std::uint64_t triangles = 0;
    double prepareSeconds = 0.0;
    const auto t0 = std::chrono::steady_clock::now();
    if (a->mode == "mesh") {
      vk::RenderStyle style;
      style.wireframe = a->wireframe;
      style.samples = std::uint32_t(a->samples);
      // The image's attachments first: one too large for the device fails before the polygonizing,
      // naming the options that size it.
      try {
        renderer = std::make_unique<vk::MeshRenderer>(device, width, height, style);
      } catch (const vk::VulkanError& e) {  // the allocator's advice names the polygonizer's knobs
        if (e.result() != VK_ERROR_OUT_OF_DEVICE_MEMORY && e.result() != VK_ERROR_OUT_OF_HOST_MEMORY) throw;
        throw std::runtime_error("a " + std::to_string(width) + "x" + std::to_string(height) + " image at " +
                                 std::to_string(style.samples) + "x MSAA does not fit this device's memory (" +
                                 (e.result() == VK_ERROR_OUT_OF_DEVICE_MEMORY ? "out of device memory" : "out of host memory") +
                                 "); lower --size or --samples, or use --mode raycast");
      }
      const blobtree::GridSpec grid = gridFor(model, a->cellSize, a->resolution);
      // The wireframe's edge list is built from the mesh on the host, so with --wireframe the vk
      // backend's mesh is read back (the generic path below) instead of drawn in place.
      if (a->settings.backend == "vk" && !a->wireframe) {
        Progress::note("render", "polygonizing on the vk backend");
        gpuMesh = vk::polygonizeForDrawing(device, model.program, grid);
        view = gpuMesh.view();
        triangles = gpuMesh.triangleCount(device);
        what = "mesh, vk backend (drawn from the GPU, " +
               std::string(gpuMesh.fromReadback ? "multi-slab grid: read back)" : "no read-back)") + ", " +
               std::to_string(triangles) + " triangles";
      } else {
        PolygonizeStats stats;
        Progress::note("render", "polygonizing on the " + a->settings.backend + " backend");
        const mesh::TriMesh mesh = polygonize(model.program, grid, a->settings, &stats);
        uploaded = vk::uploadMesh(device, mesh, style);
        view = uploaded.view();
        triangles = mesh.triangleCount();
        what = "mesh, " + a->settings.backend + " backend, " + std::to_string(triangles) + " triangles";
      }
      // Drawn all the same (the background is a valid image), but not without a word.
      if (triangles == 0) warnEmptyMesh("blobvk render", grid.cells.x, grid.cells.y, grid.cells.z);
      what += ", " + std::to_string(renderer->samples()) + "x MSAA";
    } else {
      vk::RaycastOptions rayOptions;
      rayOptions.unboundedRegion = viewBounds(model);
      raycaster = std::make_unique<vk::Raycaster>(device, model.program, rayOptions);
      char buf[96];
      const auto& cells = raycaster->lipschitzCells();
      std::snprintf(buf, sizeof(buf), "ray-cast, Lipschitz bound %.3g (largest of %ux%ux%u cells)",
                    raycaster->lipschitz(), cells.dims[0], cells.dims[1], cells.dims[2]);
      what = buf;
    }
    prepareSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

    Progress progress("render", a->turntable);
    double renderSeconds = 0.0, pngSeconds = 0.0;
    std::uint64_t exhaustedRays = 0;
    // A failed turntable leaves no frames behind: the up-front check saw the first and last
    // names only, and a frame between them may still fail.
    int written = 0;
    try {
      for (int frame = 0; frame < a->turntable; ++frame) {
        const vk::Camera c = vk::turned(camera, 360.0f * float(frame) / float(a->turntable));
        vk::Image image;
        if (renderer) {
          image = renderer->render(view, c);
          renderSeconds += renderer->lastSeconds();
        } else {
          vk::RaycastStats stats;
          image = raycaster->render(c, width, height, &stats);
          renderSeconds += stats.seconds;
          exhaustedRays += stats.exhaustedRays;
        }
        const auto tp = std::chrono::steady_clock::now();
        // Placed as every output is (cli_conventions.h): "-" is standard output as it stands (a
        // file opened for appending stays so), a file is replaced only once whole.
        writeOutput(toStdout ? std::string("-") : framePath(a->out, frame, a->turntable), vk::encodePng(image));
        ++written;
        pngSeconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - tp).count();
        progress.update(frame + 1);
      }
    } catch (...) {
      std::error_code ignored;
      for (int f = 0; a->turntable > 1 && f < written; ++f) std::filesystem::remove(framePath(a->out, f, a->turntable), ignored);
      throw;
    }
    if (exhaustedRays > 0) {
      // Not an error (the image is written), but never silent: those pixels may hide a surface.
      std::fprintf(stderr, "blobvk render: warning: %llu ray(s) ran out of their step budget (or, on lavapipe, "
                           "of the driver's loop iterations); their pixels are magenta (see docs/rendering.md, "
                           "Ray-casting)\n",
                   static_cast<unsigned long long>(exhaustedRays));
    }
    if (ctx.validationMessages() > 0) {
      throw std::runtime_error(std::to_string(ctx.validationMessages()) + " Vulkan validation message(s)");
    }
    if (!quiet() && !toStdout) {
      std::printf("%s: %ux%u, %s on %s\n", framePath(a->out, 0, a->turntable).c_str(), width, height,
                  what.c_str(), device.info().name.c_str());
      std::printf("prepare %.3f s, render %.3f s (%d frame%s, PNG encoding excluded), PNG %.3f s\n",
                  prepareSeconds, renderSeconds, a->turntable, a->turntable > 1 ? "s" : "", pngSeconds);
    }
#endif
  });
}

}  // namespace blobvk::app
