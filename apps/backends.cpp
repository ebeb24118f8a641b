#include "backends.h"

#include "cli_conventions.h"
#include "json_report.h"

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "blobvk/cpu_simd/column_sides.h"
#include "blobvk/cpu_simd/mpu_polygonizer.h"
#include "blobvk/cpu_simd/reference_polygonizer.h"
#include "blobvk/cpu_simd/streaming_polygonizer.h"

#ifdef BLOBVK_HAVE_VULKAN
#include "blobvk/vk/extract/kernel_warm_up.h"
#include "blobvk/vk/extract/multi_device.h"
#include "blobvk/vk/extract/polygonize.h"
#include "blobvk/vk/extract/streamed_extract.h"
#include "blobvk/vk/device/standalone.h"
#endif

#include <algorithm>
#include <chrono>
#include <map>
#include <memory>
#include <optional>
#include <tuple>
#include <stdexcept>

namespace blobvk::app {

std::vector<std::string> backendNames() {
  std::vector<std::string> names{"cpu", "reference"};
#ifdef BLOBVK_HAVE_VULKAN
  names.push_back("vk");
#endif
  return names;
}

std::vector<std::string> allBackendNames() { return {"cpu", "reference", "vk"}; }

std::vector<std::string> traversalNames() { return {"auto", "specialised", "stackless", "stack"}; }

#ifdef BLOBVK_HAVE_VULKAN
vk::Traversal traversalFromName(const std::string& name) {
  if (name == "auto") return vk::Traversal::Auto;
  if (name == "specialised") return vk::Traversal::Specialised;
  if (name == "stackless") return vk::Traversal::Stackless;
  if (name == "stack") return vk::Traversal::StackBased;
  throw std::invalid_argument("unknown traversal '" + name + "' (known: auto, specialised, stackless, stack)");
}

namespace {
// Released by releaseSharedDevices() before main returns, not by a static destructor: a driver
// loaded after this map was constructed (NVIDIA's) runs its exit handlers before such a
// destructor would, and destroying a device after them crashes the process at exit.
// Keyed by (device, validation, copy): --devices may open one device several times.
using ContextKey = std::tuple<std::string, bool, int>;
std::map<ContextKey, std::unique_ptr<vk::StandaloneContext>>& sharedContexts() {
  static std::map<ContextKey, std::unique_ptr<vk::StandaloneContext>> contexts;
  return contexts;
}
// A cold first process on lavapipe compiles the first job's kernels on a second device beside
// the job (vk/extract/kernel_warm_up.h); it stops copying once that job is done (later jobs find
// their kernels built) and ends before the contexts go.
std::unique_ptr<vk::KernelWarmUp>& kernelWarmUp() {
  static std::unique_ptr<vk::KernelWarmUp> warmUp;
  return warmUp;
}
// Once per process, for a job on one device: not under validation (the second device's messages
// would not be the job's) and not beside other devices (--devices, --cpu-worker: they have the
// cores).
void startWarmUp(vk::StandaloneContext& context, const PolygonizeSettings& settings) {
  if (kernelWarmUp() || settings.validation) return;
  vk::StandaloneOptions options;
  options.device = settings.device;
  kernelWarmUp() = std::make_unique<vk::KernelWarmUp>(context, options);
}
void firstJobDone() {
  if (kernelWarmUp()) kernelWarmUp()->stop();
}

vk::StandaloneContext& sharedContext(const std::string& device, bool validation, int copy = 0) {
  auto& slot = sharedContexts()[{device, validation, copy}];
  if (!slot) {
    vk::StandaloneOptions options;
    options.device = device;
    options.validation = validation;
    slot = std::make_unique<vk::StandaloneContext>(options);
  }
  return *slot;
}
// The contexts --devices names, in list order: the k-th mention of a device opens its k-th copy.
std::vector<vk::StandaloneContext*> listedContexts(const std::string& list, bool validation) {
  std::vector<vk::StandaloneContext*> contexts;
  std::map<std::size_t, int> mentions;
  for (std::size_t index : vk::resolveDeviceList(list, vk::listDevices()))
    contexts.push_back(&sharedContext(std::to_string(index), validation, mentions[index]++));
  return contexts;
}

// The contexts the vk backend runs `settings` on: the one device, or those --devices lists.
std::vector<vk::StandaloneContext*> contextsFor(const PolygonizeSettings& settings) {
  if (settings.devices.empty()) return {&sharedContext(settings.device, settings.validation)};
  return listedContexts(settings.devices, settings.validation);
}

std::uint64_t validationMessages(const std::vector<vk::StandaloneContext*>& contexts) {
  std::uint64_t n = 0;
  for (const vk::StandaloneContext* c : contexts) n += c->validationMessages();
  return n;
}
}  // namespace
#endif

void releaseSharedDevices() {
#ifdef BLOBVK_HAVE_VULKAN
  kernelWarmUp().reset();
  sharedContexts().clear();
#endif
}

void checkDeviceList([[maybe_unused]] const PolygonizeSettings& settings) {
  if (settings.devices.empty()) return;
#ifdef BLOBVK_HAVE_VULKAN
  vk::resolveDeviceList(settings.devices, vk::listDevices());
#else
  throw std::runtime_error("--devices: this blobvk was built without Vulkan (BLOBVK_WITH_VULKAN=OFF)");
#endif
}

nlohmann::json backendDeviceJson([[maybe_unused]] const PolygonizeSettings& settings) {
#ifdef BLOBVK_HAVE_VULKAN
  if (!settings.devices.empty()) {
    nlohmann::json list = nlohmann::json::array();
    for (vk::StandaloneContext* c : listedContexts(settings.devices, settings.validation))
      list.push_back(deviceJson(c->host().physicalDevice));
    return list;
  }
  return deviceJson(sharedContext(settings.device, settings.validation).host().physicalDevice);
#else
  return nlohmann::json::object();
#endif
}

double waitForBackgroundBuilds([[maybe_unused]] const PolygonizeSettings& settings) {
  const auto start = std::chrono::steady_clock::now();
#ifdef BLOBVK_HAVE_VULKAN
  if (settings.backend == "vk") {
    for (vk::StandaloneContext* c : contextsFor(settings)) c->device().waitForBackgroundBuilds();
  }
#endif
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

#ifdef BLOBVK_HAVE_VULKAN
namespace {
vk::GpuPolygonizeOptions gpuOptions(const PolygonizeSettings& settings, const blobtree::Program& program) {
  vk::GpuPolygonizeOptions options;
  // On llvmpipe the field pass skips the rows the CPU backend's bound proves one-sided, where the
  // bound holds for the device's values (no sin or cos; Ricci powers within a margin).
  if (settings.rowCulling && cpu::ColumnSides::boundsHoldOnIeeeDevices(program)) {
    options.columnSides = [sides = std::make_shared<cpu::ColumnSides>(program)](
                              const float* x, std::uint32_t nx, const float* y, const float* z, std::uint32_t n,
                              std::uint8_t* out) { (*sides)(x, nx, y, z, n, out); };
  }
  options.hostPassesOnCpuDevices = settings.hostPasses;
  options.refineSteps = settings.refineSteps;
  options.traversal = traversalFromName(settings.traversal);
  if (settings.fieldTiles > 0)  // a given cap holds for repeated jobs too
    options.maxFieldTiles = options.repeatedJobFieldTiles = options.maxFieldTilesForLoopedCode =
        std::uint32_t(settings.fieldTiles);
  if (settings.brickCells > 0) options.brickCells = std::uint32_t(settings.brickCells);
  options.sparse = !settings.dense;
  options.tiledVertexPass = settings.tiledVertices;
  options.sparseVertexTiles = settings.vertexTiles;
  options.brickTapes = settings.brickTapes;
  options.phaseNote = settings.phaseNote;
  options.classifyProgress = settings.classifyProgress;
  if (settings.batchesPerDevice > 0) options.batchesPerDevice = std::uint32_t(settings.batchesPerDevice);
  options.expectedRuns = std::uint32_t(std::max(settings.expectedRuns, 1));
  return options;
}

// The evaluator the job's vertex pass ran: the one the batches report, else the one asked for.
vk::Traversal ranTraversal(const vk::GpuPolygonizeOptions& options, const vk::GpuStats& gpu) {
  return gpu.traversal != vk::Traversal::Auto ? gpu.traversal : options.traversal;
}

// Hands everything on to `next`, counting the vertices (for the evaluations per vertex).
class VertexCountingSink final : public mesh::MeshSink {
 public:
  explicit VertexCountingSink(mesh::MeshSink& next) : next_(next) {}
  void vertices(std::span<const mesh::Float3> positions, std::span<const mesh::Float3> normals,
                std::span<const mesh::Float3> colours) override {
    count += positions.size();
    next_.vertices(positions, normals, colours);
  }
  void triangles(std::span<const std::array<std::uint32_t, 3>> triangles, const mesh::VertexWindow& window) override {
    next_.triangles(triangles, window);
  }
  std::uint64_t count = 0;

 private:
  mesh::MeshSink& next_;
};

PolygonizeStats::Phases gpuPhases(const vk::GpuStats& gpu) {
  return {gpu.classifySeconds, gpu.fieldSeconds, gpu.extractSeconds, gpu.readbackSeconds,
          gpu.hostSeconds, gpu.bricks, gpu.activeBricks, gpu.brickCells, gpu.deviceBytes,
          gpu.submits, gpu.batches, gpu.deviceTimed, gpu.devices,
          gpu.traversal == vk::Traversal::Auto ? std::string() : std::string(vk::traversalName(gpu.traversal)),
          gpu.vertexGradient, gpu.vertexUniforms, gpu.vertexTapes, gpu.hostClassification, gpu.modelBuildSeconds, gpu.modelRunSeconds,
          gpu.edgesSeconds, gpu.scansSeconds, gpu.sourcesSeconds, gpu.verticesSeconds, gpu.trianglesSeconds,
          gpu.fieldTiles, gpu.vertexTiles, gpu.generatedClassification, gpu.classifyTiles, gpu.tapeInstructions, gpu.tapeWords,
          gpu.tapeSeconds, gpu.readbackDeviceSeconds,
          {gpu.hostSteps.classification, gpu.hostSteps.preparation, gpu.hostSteps.fieldSubmits, gpu.hostSteps.emitSubmits,
           gpu.hostSteps.grow, gpu.hostSteps.copy, gpu.hostSteps.corners, gpu.hostSteps.rowCulling,
           gpu.hostSteps.scans, gpu.hostSteps.vertexTileLists, gpu.hostSteps.rows, gpu.hostSteps.sources,
           gpu.hostSteps.triangles},
          gpu.vertexTapeWindows};
}

// `--cpu-worker`: the CPU polygonizer takes batches beside the devices. Its MPUs are the bricks,
// so its layers are the batches' brick layers; its polygonizer is made on the worker's thread,
// once the job's brick size is known.
class CpuBatchWorker {
 public:
  CpuBatchWorker(const blobtree::Program& program, const blobtree::GridSpec& grid, const PolygonizeSettings& settings) {
    worker_.run = [this, &program, grid, threads = settings.threads, refine = settings.refineSteps](
                      std::uint32_t first, std::uint32_t end, std::uint32_t brickCells) {
      if (!layers_) {
        cpu::MpuOptions o;
        o.threads = threads > 0 ? threads : 1;
        o.refineSteps = refine;
        o.mpuCells = int(brickCells);
        layers_ = std::make_unique<cpu::LayerPolygonizer>(program, grid, o);
      }
      return cpu::polygonizeLayerRange(*layers_, int(first), int(end));
    };
  }
  CpuBatchWorker(const CpuBatchWorker&) = delete;
  CpuBatchWorker& operator=(const CpuBatchWorker&) = delete;
  const vk::HostBatchWorker* get() const { return &worker_; }

 private:
  std::unique_ptr<cpu::LayerPolygonizer> layers_;
  vk::HostBatchWorker worker_;
};

std::vector<vk::Device*> devicesOf(const std::vector<vk::StandaloneContext*>& contexts) {
  std::vector<vk::Device*> devices;
  for (vk::StandaloneContext* c : contexts) devices.push_back(&c->device());
  return devices;
}

void checkValidation(const std::vector<vk::StandaloneContext*>& contexts, std::uint64_t messagesBefore) {
  if (validationMessages(contexts) != messagesBefore) {
    throw std::runtime_error("the Vulkan validation layer reported " +
                             std::to_string(validationMessages(contexts) - messagesBefore) + " message(s)");
  }
}
}  // namespace
#endif

void polygonizeStreamed(const blobtree::Program& program, const blobtree::GridSpec& grid,
                        const PolygonizeSettings& settings, mesh::MeshSink& sink, PolygonizeStats* stats) {
  if (settings.backend != "vk") throw std::invalid_argument("polygonizeStreamed: the vk backend only, not " + settings.backend);
#ifdef BLOBVK_HAVE_VULKAN
  const auto start = std::chrono::steady_clock::now();
  const std::vector<vk::StandaloneContext*> contexts = contextsFor(settings);
  const std::uint64_t messagesBefore = validationMessages(contexts);
  vk::GpuStats gpu;
  const auto progress = settings.progress ? std::function<void(std::size_t, std::size_t)>(settings.progress)
                                          : std::function<void(std::size_t, std::size_t)>();
  const vk::GpuPolygonizeOptions options = gpuOptions(settings, program);
  VertexCountingSink counted(sink);
  if (contexts.size() == 1 && !settings.cpuWorker) {
    startWarmUp(*contexts[0], settings);
    vk::polygonizeStreamed(contexts[0]->device(), program, grid, options, counted, &gpu, progress);
  } else {
    std::optional<CpuBatchWorker> cpu = settings.cpuWorker ? std::make_optional<CpuBatchWorker>(program, grid, settings) : std::nullopt;
    vk::polygonizeOnDevicesStreamed(devicesOf(contexts), program, grid, options, counted, &gpu, nullptr,
                                    cpu ? cpu->get() : nullptr, progress);
  }
  firstJobDone();
  checkValidation(contexts, messagesBefore);
  if (stats) {
    stats->gpu = gpuPhases(gpu);
    stats->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    stats->pointEvaluations = double(gpu.fieldEvaluations) +
                              double(counted.count) * vk::evaluationsPerVertex(options, ranTraversal(options, gpu));
  }
#else
  (void)program, (void)grid, (void)sink, (void)stats;
  throw std::runtime_error("the vk backend: this blobvk was built without Vulkan (BLOBVK_WITH_VULKAN=OFF)");
#endif
}

mesh::TriMesh polygonize(const blobtree::Program& program, const blobtree::GridSpec& grid,
                         const PolygonizeSettings& settings, PolygonizeStats* stats, mesh::TriMesh recycled) {
  const auto start = std::chrono::steady_clock::now();
  mesh::TriMesh mesh;
  double evaluations = 0.0;
  if (settings.backend == "cpu") {
    cpu::MpuOptions options;
    options.threads = settings.threads;
    options.refineSteps = settings.refineSteps;
    options.progress = settings.progress;
    // A whole mesh: the library's whole-mesh MPU size and leaves unless both are given.
    options.mpuCells = settings.mpuSize > 0 ? settings.mpuSize : cpu::kWholeMeshMpuCells;
    options.subBlockCells = settings.subBlockCells >= 0 ? settings.subBlockCells
                            : settings.mpuSize > 0  ? cpu::kDefaultSubBlockCells
                                                    : cpu::kWholeMeshSubBlockCells;
    cpu::MpuStats mpu;
    if (settings.cpuPolygonizer) {
      mesh = std::move(recycled);
      settings.cpuPolygonizer->polygonize(program, grid, options, mesh, &mpu);
    } else {
      mesh = cpu::polygonizeMpu(program, grid, options, &mpu);
    }
    evaluations = double(mpu.pointEvaluations);
    if (stats) {
      const double parts[] = {mpu.cpuDiscard + mpu.cpuPrune, mpu.cpuField, mpu.cpuVertices, mpu.cpuAttributes, mpu.cpuCells};
      double cpuSum = 0.0;
      for (double v : parts) cpuSum += v;
      const double share = cpuSum > 0.0 ? mpu.msMpus / cpuSum * 1e-3 : 0.0;  // ms of CPU -> s of wall
      const char* names[] = {"classification", "field", "vertices", "normals_colours", "triangles"};
      stats->phaseSeconds.clear();
      stats->phaseSeconds.emplace_back("setup", mpu.msSetup * 1e-3);
      for (int i = 0; i < 5; ++i) stats->phaseSeconds.emplace_back(names[i], parts[i] * share);
      stats->phaseSeconds.emplace_back("welding", (mpu.msPrefix + mpu.msScatter) * 1e-3);
    }
  } else if (settings.backend == "reference") {
    cpu::ReferenceOptions options;
    options.refineSteps = settings.refineSteps;
    mesh = cpu::polygonizeReference(program, grid, options);
    // Every grid point, then per vertex its refinement steps (at most) and one gradient pass.
    evaluations = double(grid.pointCount()) + double(mesh.positions.size()) * double(std::max(options.refineSteps, 0) + 1);
#ifdef BLOBVK_HAVE_VULKAN
  } else if (settings.backend == "vk") {
    const std::vector<vk::StandaloneContext*> contexts = contextsFor(settings);
    const std::uint64_t messagesBefore = validationMessages(contexts);
    const vk::GpuPolygonizeOptions options = gpuOptions(settings, program);
    vk::GpuStats gpu;
    if (contexts.size() == 1 && !settings.cpuWorker) {
      startWarmUp(*contexts[0], settings);
      mesh = std::move(recycled);
      vk::polygonizeInto(contexts[0]->device(), program, grid, options, mesh, &gpu);
    } else {
      std::optional<CpuBatchWorker> cpu = settings.cpuWorker ? std::make_optional<CpuBatchWorker>(program, grid, settings) : std::nullopt;
      mesh = vk::polygonizeOnDevices(devicesOf(contexts), program, grid, options, &gpu, nullptr, cpu ? cpu->get() : nullptr);
    }
    firstJobDone();
    evaluations = double(gpu.fieldEvaluations) +
                  double(mesh.positions.size()) * vk::evaluationsPerVertex(options, ranTraversal(options, gpu));
    if (stats) stats->gpu = gpuPhases(gpu);
    checkValidation(contexts, messagesBefore);
#else
  } else if (settings.backend == "vk") {
    throw std::runtime_error("the vk backend: this blobvk was built without Vulkan (BLOBVK_WITH_VULKAN=OFF)");
#endif
  } else {
    std::string known;
    for (const std::string& n : backendNames()) known += (known.empty() ? "" : ", ") + n;
    throw std::invalid_argument("unknown backend '" + settings.backend + "' (known: " + known + ")");
  }
  if (stats) {
    stats->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    stats->pointEvaluations = evaluations;
  }
  return mesh;
}

void refuseOptionsNoBackendUses(const CLI::App& command, const std::vector<std::string>& backends) {
  const auto uses = [&backends](const char* backend) {
    return std::find(backends.begin(), backends.end(), backend) != backends.end();
  };
  // bench's options are lists: count() is how often one was given, results() every value.
  const auto given = [&command](const char* option) {
    const CLI::Option* o = command.get_option_no_throw(option);
    return o && o->count() > 0;
  };
  const auto values = [&command, &given](const char* option) {
    return given(option) ? command.get_option_no_throw(option)->results() : std::vector<std::string>{};
  };
  const auto refuse = [&given](std::initializer_list<const char*> options, const char* forWhom) {
    for (const char* option : options)
      if (given(option)) throw UsageError(std::string(option) + " is for " + forWhom);
  };
  if (!uses("vk"))
    refuse({"--device", "--devices", "--cpu-worker", "--validation", "--traversal", "--brick-cells", "--field-tiles",
            "--tiled-vertices", "--vertex-tiles", "--brick-tapes", "--no-row-culling", "--device-passes", "--dense",
            "--batches-per-device"},
           "the vk backend");
  // The vk backend's CPU worker meshes on --threads threads, in MPUs of the brick size (not --mpu).
  if (!uses("cpu")) refuse({"--mpu", "--sub-block"}, "the cpu backend");
  if (!uses("cpu") && !(uses("vk") && given("--cpu-worker")))
    refuse({"--threads"}, "the cpu backend and the vk backend's --cpu-worker");
  if (!given("--devices")) refuse({"--batches-per-device"}, "several devices (--devices)");
  // Within the vk backend: the pruned kernels are the specialised traversal's, the bricks the
  // sparse extraction's.
  const std::vector<std::string> traversals = values("--traversal");
  if (!traversals.empty() && std::none_of(traversals.begin(), traversals.end(),
                                          [](const std::string& t) { return t == "auto" || t == "specialised"; }))
    refuse({"--field-tiles", "--vertex-tiles"}, "the specialised traversal (--traversal auto or specialised)");
  if (given("--dense"))
    refuse({"--brick-cells", "--vertex-tiles", "--brick-tapes", "--no-row-culling", "--device-passes", "--cpu-worker"},
           "the sparse extraction, not --dense");
  const std::vector<std::string> fieldTiles = values("--field-tiles");
  if (!fieldTiles.empty() && fieldTiles.back() == "1")
    refuse({"--vertex-tiles"}, "more than one field tile (--field-tiles 1 makes one)");
}

}  // namespace blobvk::app
