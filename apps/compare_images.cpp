// `blobvk compare --images`: the CPU mesh and the GPU mesh through the same raster pipeline, and
// the ray-cast field, all from the same camera at one sample per pixel (so the three sample the
// same pixel centres), compared pairwise.
#include "compare_images.h"

#include "backends.h"
#include "cli_conventions.h"

#include <glm/glm.hpp>
#include <nlohmann/json.hpp>

#ifdef BLOBVK_HAVE_VULKAN
#include "blobvk/vk/render/png_io.h"
#include "blobvk/vk/render/raycast.h"
#include "blobvk/vk/render/render_gpu_mesh.h"
#include "blobvk/vk/render/render_image.h"
#include "blobvk/vk/render/render_mesh.h"
#include "blobvk/vk/device/standalone.h"
#endif

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <stdexcept>

namespace blobvk::app {

bool compareImages(const Model& model, const blobtree::GridSpec& grid, const ImageCompareSettings& settings,
                   nlohmann::json& report) {
#ifndef BLOBVK_HAVE_VULKAN
  (void)model;
  (void)grid;
  (void)settings;
  (void)report;
  throw std::runtime_error("compare --images needs the Vulkan backend (built with BLOBVK_WITH_VULKAN=OFF)");
#else
  if (settings.width < 1 || settings.height < 1) throw std::invalid_argument("image size must be positive");
  const auto width = std::uint32_t(settings.width), height = std::uint32_t(settings.height);
  vk::StandaloneOptions options;
  options.device = settings.device;
  options.validation = settings.validation;
  vk::StandaloneContext ctx(options);
  auto& device = ctx.device();
  const vk::Camera camera = vk::resolveCamera(viewBounds(model), model.scene.camera, {},
                                              float(width) / float(height));
  vk::RenderStyle style;
  style.samples = 1;
  vk::MeshRenderer renderer(device, width, height, style);

  PolygonizeSettings cpuSettings;
  cpuSettings.backend = "cpu";
  const vk::Image cpuMesh = renderer.render(polygonize(model.program, grid, cpuSettings), camera);
  const vk::GpuMesh gpu = vk::polygonizeForDrawing(device, model.program, grid);
  const vk::Image gpuMesh = renderer.render(gpu.view(), camera);
  vk::RaycastOptions rayOptions;
  rayOptions.background = style.background;
  rayOptions.unboundedRegion = viewBounds(model);
  vk::RaycastStats rayStats;
  const vk::Image raycast = vk::Raycaster(device, model.program, rayOptions).render(camera, width, height, &rayStats);

  struct Named {
    const char* name;
    const vk::Image* image;
  };
  const Named images[3] = {{"cpu_mesh", &cpuMesh}, {"gpu_mesh", &gpuMesh}, {"raycast", &raycast}};
  const std::pair<int, int> pairs[2] = {{0, 1}, {0, 2}};
  // The meshes must agree pixel for pixel; a mesh and the ray-cast only within the mesh's own
  // error: marching cubes cuts a sharp crease or corner by up to the diagonal of a cell, so two
  // cells, in pixels at the target's distance.
  const float targetDistance = glm::length(camera.eye - camera.target);
  const float pixelsPerUnit = float(height) / (2.0f * targetDistance * std::tan(glm::radians(camera.fovYDeg) * 0.5f));
  // At most 16 pixels: a coarse grid on a large image would otherwise let any colour near a
  // pixel match it (and cost a search of the whole window per pixel).
  const int meshErrorPixels = int(std::ceil(std::min(2.0f * grid.cellSize * pixelsPerUnit, 16.0f)));
  report["width"] = width;
  report["height"] = height;
  report["tolerance"] = settings.tolerance;
  report["max_fraction_over"] = settings.maxFractionOver;
  report["device"] = device.info().name;
  report["raycast_lipschitz"] = rayStats.lipschitz;
  report["raycast_rays_out_of_budget"] = rayStats.exhaustedRays;  // drawn magenta, never silent
  report["gpu_mesh_drawn_without_readback"] = !gpu.fromReadback;
  bool pass = true;
  nlohmann::json list = nlohmann::json::array();
  for (const auto& [i, j] : pairs) {
    const int radius = j == 2 ? meshErrorPixels : 0;
    const auto d = vk::compareImagesWithin(*images[i].image, *images[j].image, settings.tolerance, radius);
    const bool ok = d.fractionOver <= settings.maxFractionOver;
    pass = pass && ok;
    nlohmann::json entry;
    entry["a"] = images[i].name;
    entry["b"] = images[j].name;
    entry["max_difference"] = d.maxDifference;
    entry["fraction_over_tolerance"] = d.fractionOver;
    entry["search_radius_px"] = radius;
    entry["mean_difference"] = d.meanDifference;
    entry["psnr_db"] = std::isinf(d.psnr) ? nlohmann::json(nullptr) : nlohmann::json(d.psnr);  // null: identical
    entry["pass"] = ok;
    list.push_back(entry);
    if (!settings.writeDir.empty()) {
      std::filesystem::create_directories(settings.writeDir);
      writeOutput(settings.writeDir + "/diff_" + images[i].name + "_" + images[j].name + ".png",
                  vk::encodePng(vk::differenceImage(*images[i].image, *images[j].image)));
    }
  }
  if (!settings.writeDir.empty()) {
    for (const auto& n : images) writeOutput(settings.writeDir + "/" + n.name + ".png", vk::encodePng(*n.image));
  }
  report["pairs"] = list;
  report["validation_messages"] = ctx.validationMessages();
  if (ctx.validationMessages() > 0) pass = false;
  report["pass"] = pass;
  return pass;
#endif
}

}  // namespace blobvk::app
