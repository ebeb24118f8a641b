// `blobvk compare SCENE`: the CPU and Vulkan backends on the same grid, compared field by field,
// cell by cell and mesh by mesh. A non-zero exit (3) when a threshold is exceeded, so users can
// put it in their CI.
#include "backends.h"
#include "cli_conventions.h"
#include "number_checks.h"
#include "commands.h"
#include "json_report.h"
#include "progress.h"
#include "resolution_limit.h"
#include "compare_images.h"
#include "mesh_distance.h"
#include "model.h"

#include "blobvk/cpu_simd/sharp_features.h"
#include "blobvk/cpu_simd/simd_evaluator.h"

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <unistd.h>

#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>
#include <stdexcept>

#ifdef BLOBVK_HAVE_VULKAN
#include "blobvk/vk/eval/field.h"
#include "blobvk/vk/device/standalone.h"
#endif

namespace blobvk::app {
namespace {

// (Only the Vulkan build compares; a CPU-only build keeps the command to say so.)
[[maybe_unused]] std::vector<float> cpuField(const blobtree::Program& program, const blobtree::GridSpec& grid) {
  const glm::ivec3 n = grid.points();
  std::vector<float> field(grid.pointCount());
  std::vector<float> x(std::size_t(n.x)), y(std::size_t(n.x)), z(std::size_t(n.x));
  const cpu::SimdLevel level = cpu::bestSimdLevel();
  for (int k = 0; k < n.z; ++k)
    for (int j = 0; j < n.y; ++j) {
      for (int i = 0; i < n.x; ++i) {
        const glm::vec3 p = grid.point(i, j, k);
        x[std::size_t(i)] = p.x;
        y[std::size_t(i)] = p.y;
        z[std::size_t(i)] = p.z;
      }
      cpu::evaluateFieldBatch(program, x.data(), y.data(), z.data(), &field[grid.pointIndex(0, j, k)],
                              std::size_t(n.x), level);
    }
  return field;
}

// The shortest text that reads back as the same double, so a threshold of 0 and a difference of
// 3e-9 never both print as 0.000000.
[[maybe_unused]] std::string shortest(double v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

struct CellDiff {
  std::uint64_t cellsDiffering = 0, explained = 0;
};

// Cells whose inside/outside configuration differs, and whether each differing corner sits
// within eps of the iso value on the CPU side (a legitimate rounding disagreement).
[[maybe_unused]] CellDiff compareCells(const std::vector<float>& a, const std::vector<float>& b, const blobtree::GridSpec& grid, float eps) {
  CellDiff d;
  const float iso = layout::ISO_VALUE;
  for (int k = 0; k < grid.cells.z; ++k)
    for (int j = 0; j < grid.cells.y; ++j)
      for (int i = 0; i < grid.cells.x; ++i) {
        bool differs = false, explained = true;
        for (int c = 0; c < 8; ++c) {
          const std::uint64_t idx = grid.pointIndex(i + (c & 1), j + ((c >> 1) & 1), k + ((c >> 2) & 1));
          if ((a[idx] >= iso) != (b[idx] >= iso)) {
            differs = true;
            explained = explained && std::abs(a[idx] - iso) <= eps;
          }
        }
        if (differs) {
          ++d.cellsDiffering;
          if (explained) ++d.explained;
        }
      }
  return d;
}

}  // namespace

void addCompareCommand(CLI::App& app) {
  struct Args {
    std::string scene, bounds;
    std::optional<int> resolution;
    std::optional<float> cellSize;
    std::string cpuBackend = "cpu";
    std::string device, traversal = "auto";
    bool validation = false, json = false, images = false, features = false;
    double maxFieldDiff = 1e-4, maxHausdorffCells = 0.05;
    ImageCompareSettings imageSettings;
  };
  auto a = std::make_shared<Args>();
  auto* cmd = app.add_subcommand("compare", "Compare the CPU and Vulkan backends on a scene");
  cmd->add_option("scene", a->scene, "Scene file (.json, .blob, .scene)")->required();
  cmd->add_option("--bounds", a->bounds, kGridBoundsHelp)->check(gridBounds());
  auto* res = cmd->add_option("--resolution", a->resolution, "Cells along the longest side (default 64)")->check(resolutionRange(2));
  cmd->add_option("--cell-size", a->cellSize, "Grid cell size")->check(cellSize())->excludes(res);
  cmd->add_option("--cpu-backend", a->cpuBackend, "CPU side: cpu (MPU + AVX) or reference")
      ->check(CLI::IsMember({"cpu", "reference"}));
  cmd->add_option("--device", a->device, "Vulkan device (name substring or index)")->check(nonEmptyText());
  cmd->add_flag("--validation", a->validation, "Run the Vulkan side under the validation layer");
  cmd->add_option("--traversal", a->traversal, "Vulkan evaluator: auto (default: the cost model picks per job), specialised, stackless or stack")
      ->check(CLI::IsMember(traversalNames()));
  // A NaN threshold would pass every comparison (every test against it is false).
  const CLI::Validator finiteNonNegative = nonNegativeFinite();
  cmd->add_option("--max-field-diff", a->maxFieldDiff, "Fail above this max |field difference| (default 1e-4)")
      ->check(finiteNonNegative);
  cmd->add_option("--max-hausdorff", a->maxHausdorffCells, "Fail above this Hausdorff distance, in cells (default 0.05)")
      ->check(finiteNonNegative);
  cmd->add_flag("--features", a->features, "Compare the meshes after the sharp-feature pass (blobvk mesh --features)");
  auto* images = cmd->add_flag("--images", a->images, "Also render CPU mesh, GPU mesh and ray-cast and compare pixels");
  // Without --images nothing is rendered: these would do nothing, so they need it.
  cmd->add_option("--image-size", a->imageSettings.width, "Image side in pixels (default 256; with --images)")
      ->check(CLI::Range(16, kMaxImageSide))
      ->needs(images);
  cmd->add_option("--write-images", a->imageSettings.writeDir, "Folder for the rendered images (with --images)")->needs(images);
  cmd->add_flag("--json", a->json, "Print the report as JSON (with the blobvk version, device and driver)");
  cmd->callback([a] {
    // The image folder before any work, as every output is checked first.
    if (!a->imageSettings.writeDir.empty()) {
      const std::string& dir = a->imageSettings.writeDir;
      std::error_code ec;
      std::filesystem::create_directories(dir, ec);
      if (ec) throw std::runtime_error(dir + ": cannot create the image folder: " + ec.message());
      if (!std::filesystem::is_directory(dir, ec)) throw std::runtime_error(dir + ": is not a folder (--write-images)");
      if (::access(dir.c_str(), W_OK) != 0) throw std::runtime_error(dir + ": cannot write into the image folder: " + std::strerror(errno));
    }
#ifndef BLOBVK_HAVE_VULKAN
    throw std::runtime_error("this blobvk was built without Vulkan (BLOBVK_WITH_VULKAN=OFF)");
#else
    Model model = loadModel(a->scene);
    applyGridBounds(model, a->bounds);
    const blobtree::GridSpec grid = gridFor(model, a->cellSize, a->cellSize ? a->resolution : a->resolution.value_or(64));
    nlohmann::json report = versionJson();
    report["scene"] = a->scene;
    report["traversal"] = a->traversal;  // as asked (auto: the cost model's choice per job)
    report["cpu_backend"] = a->cpuBackend;
    report["features"] = a->features;
    report["thresholds"] = {{"max_field_diff", a->maxFieldDiff}, {"max_hausdorff_cells", a->maxHausdorffCells}};
    report["grid"] = {{"cells", {grid.cells.x, grid.cells.y, grid.cells.z}}, {"cell_size", grid.cellSize}};
    Progress progress("compare", a->images ? 4 : 3);

    // Fields.
    vk::StandaloneOptions deviceOptions;
    deviceOptions.device = a->device;
    deviceOptions.validation = a->validation;
    vk::StandaloneContext context(deviceOptions);
    report["device"] = deviceJson(context.host().physicalDevice);
    vk::FieldOptions fieldOptions;
    fieldOptions.traversal = traversalFromName(a->traversal);
    const std::vector<float> gpu = vk::evaluateFieldOnGrid(context.device(), model.program, grid, fieldOptions);
    const std::vector<float> cpu = cpuField(model.program, grid);
    progress.update(1, "fields");
    double maxDiff = 0, sumDiff = 0;
    for (std::size_t i = 0; i < cpu.size(); ++i) {
      const double d = std::abs(double(cpu[i]) - double(gpu[i]));
      maxDiff = std::max(maxDiff, d);
      sumDiff += d;
    }
    // Explained: each flipped corner within the allowed field difference of the iso value. Not the
    // observed difference: a corner the two put on opposite sides always lies within that.
    const CellDiff cells = compareCells(cpu, gpu, grid, float(a->maxFieldDiff));
    report["field"] = {{"max_abs_diff", maxDiff}, {"mean_abs_diff", cpu.empty() ? 0.0 : sumDiff / double(cpu.size())},
                       {"points", cpu.size()}};
    report["cells"] = {{"differing", cells.cellsDiffering}, {"explained_by_iso_rounding", cells.explained}};

    // Meshes.
    PolygonizeSettings cpuSettings;
    cpuSettings.backend = a->cpuBackend;
    PolygonizeSettings gpuSettings;
    gpuSettings.backend = "vk";
    gpuSettings.device = a->device;
    gpuSettings.validation = a->validation;
    gpuSettings.traversal = a->traversal;
    mesh::TriMesh cpuMesh = polygonize(model.program, grid, cpuSettings);
    progress.update(2, "cpu mesh");
    mesh::TriMesh gpuMesh = polygonize(model.program, grid, gpuSettings);
    progress.update(3, "vk mesh");
    if (a->features) {
      cpu::placeSharpFeatures(cpuMesh, grid);
      cpu::placeSharpFeatures(gpuMesh, grid);
    }
    // Two empty meshes agree, and check nothing: said, as mesh and render say it.
    if (cpuMesh.triangleCount() == 0 && gpuMesh.triangleCount() == 0)
      warnEmptyMesh("blobvk compare", grid.cells.x, grid.cells.y, grid.cells.z);
    const bool sameTopology = cpuMesh.edgeKeys == gpuMesh.edgeKeys && cpuMesh.triangles == gpuMesh.triangles;
    const double hausdorff = vertexHausdorff(cpuMesh, gpuMesh, grid.cellSize);
    report["mesh"] = {{"cpu", {{"vertices", cpuMesh.vertexCount()}, {"triangles", cpuMesh.triangleCount()}}},
                      {"vk", {{"vertices", gpuMesh.vertexCount()}, {"triangles", gpuMesh.triangleCount()}}},
                      {"identical_topology", sameTopology},
                      {"hausdorff", hausdorff},
                      {"hausdorff_cells", hausdorff / grid.cellSize}};
    if (context.validationMessages() != 0) report["validation_messages"] = context.validationMessages();

    std::vector<std::string> failures;
    if (maxDiff > a->maxFieldDiff) failures.push_back("max field difference " + shortest(maxDiff) + " > " + shortest(a->maxFieldDiff));
    if (cells.explained != cells.cellsDiffering) failures.push_back(std::to_string(cells.cellsDiffering - cells.explained) + " cell(s) differ beyond iso rounding");
    if (hausdorff / grid.cellSize > a->maxHausdorffCells) failures.push_back("Hausdorff distance " + shortest(hausdorff / grid.cellSize) + " cells > " + shortest(a->maxHausdorffCells));
    if (!sameTopology && cells.cellsDiffering == 0) failures.push_back("mesh topology differs although every cell agrees");
    if (context.validationMessages() != 0) failures.push_back("validation layer messages");
    if (a->images) {
      a->imageSettings.height = a->imageSettings.width;
      a->imageSettings.device = a->device;
      a->imageSettings.validation = a->validation;
      nlohmann::json images;
      if (!compareImages(model, grid, a->imageSettings, images)) {
        std::string pairs;
        for (const auto& pair : images["pairs"])
          if (!pair["pass"].get<bool>())
            pairs += std::string(pairs.empty() ? "" : ", ") + pair["a"].get<std::string>() + " vs " + pair["b"].get<std::string>() +
                     " (" + shortest(100.0 * pair["fraction_over_tolerance"].get<double>()) + " % of pixels over, search radius " +
                     std::to_string(pair["search_radius_px"].get<int>()) + " px)";
        if (images.value("validation_messages", 0) > 0) pairs += std::string(pairs.empty() ? "" : ", ") + "validation layer messages";
        failures.push_back("images differ beyond tolerance: " + pairs);
      }
      progress.update(4, "images");
      report["images"] = images;
    }
    report["pass"] = failures.empty();
    report["failures"] = failures;

    if (a->json) {
      std::printf("%s\n", report.dump(2).c_str());
    } else {
      std::printf("%s on a %d x %d x %d grid\n", a->scene.c_str(), grid.cells.x, grid.cells.y, grid.cells.z);
      std::printf("field   max |cpu - vk| %.3g, mean %.3g over %zu points\n", maxDiff, sumDiff / double(cpu.size()), cpu.size());
      std::printf("cells   %llu differ, %llu explained by CPU samples within --max-field-diff of the iso value\n",
                  (unsigned long long)cells.cellsDiffering, (unsigned long long)cells.explained);
      std::printf("mesh    cpu %zu v / %zu t, vk %zu v / %zu t, topology %s, Hausdorff %.3g (%.3g cells)\n",
                  cpuMesh.vertexCount(), cpuMesh.triangleCount(), gpuMesh.vertexCount(), gpuMesh.triangleCount(),
                  sameTopology ? "identical" : "different", hausdorff, hausdorff / grid.cellSize);
      if (report.contains("images")) std::printf("images  %s\n", report["images"].dump().c_str());
      std::printf("%s\n", failures.empty() ? "PASS" : "FAIL");
    }
    if (!failures.empty()) {
      std::string all;
      for (const auto& f : failures) all += (all.empty() ? "" : "; ") + f;
      throw ComparisonFailed{a->scene + ": " + all};
    }
#endif
  });
}

}  // namespace blobvk::app
