// The polygonizer backends behind `mesh`, `bench` and `compare`, chosen by name. The vk backend
// keeps one device per (device, validation) for the life of the process, so repeated calls
// (bench repeats, compare) reuse its compiled pipelines.
#pragma once

#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/mesh/trimesh.h"

#include <cstdint>
#include <functional>
#include <memory>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <utility>
#include <vector>

namespace blobvk::mesh {
class MeshSink;
}

namespace blobvk::vk {
enum class Traversal;  // vk/eval/gpu_program.h
}

namespace blobvk::cpu {
class MpuPolygonizer;  // cpu_simd/mpu_polygonizer.h
}

namespace CLI {
class App;
}

namespace blobvk::app {

struct PolygonizeSettings {
  std::string backend = "cpu";  // cpu (MPU + AVX), reference (scalar, one thread), vk
  int threads = 0;              // cpu: 0 = all cores
  int refineSteps = 0;
  int mpuSize = 0;              // cpu: cells per MPU side, 0 = default
  int subBlockCells = -1;       // cpu: leaf size of the sparse field cache (0 = off, -1 = default)
  std::string device;           // vk: name substring or index
  // vk: several devices sharing the sparse extraction's batches (vk/extract/multi_device.h):
  // "all" or a comma-separated list of indices or names, a device named twice opened twice
  // (vk::resolveDeviceList). Empty: the one `device`.
  std::string devices;
  int batchesPerDevice = 0;     // vk, several devices: GpuPolygonizeOptions::batchesPerDevice (0: default)
  // vk: the CPU polygonizer takes batches of brick layers beside the Vulkan devices (the host
  // worker of vk/extract/multi_device.h), on `threads` threads (0: one, leaving the cores to the
  // devices' drivers); the bytes are the devices' alone.
  bool cpuWorker = false;
  bool validation = false;      // vk: Khronos validation layer
  // vk: auto (the cost model picks specialised or stackless per job; default), specialised (the
  // Program compiled into the kernel), stackless (the register code interpreted) or stack (the
  // stack-based tree walk: the thesis' Table 4.2 comparison).
  std::string traversal = "auto";
  int fieldTiles = 0;           // vk specialised: most tiles with pruned field kernels (1 = off; 0 = the library's defaults)
  int brickCells = 0;           // vk: cells per brick edge of the sparse extraction (0: default)
  bool dense = false;           // vk: the dense z-slab extraction instead of the sparse one
  bool tiledVertices = false;   // vk specialised: the vertex pass per tile too
  // vk sparse, specialised with field tiles: the vertex pass per tile of bricks too.
  bool vertexTiles = false;
  bool brickTapes = false;      // vk sparse: the field pass per brick, the program pruned to each brick
  // vk sparse on llvmpipe: the field pass skips rows of points the CPU backend's bound proves on
  // one side (vk::GpuPolygonizeOptions::columnSides); false: every row of an active brick.
  bool rowCulling = true;
  // vk sparse on a CPU device (lavapipe): the bookkeeping passes (classification, scans, row
  // counts, sources, triangles, vertex tile lists) on the host, in the mapped buffers
  // (vk::GpuPolygonizeOptions::hostPassesOnCpuDevices); false: as kernels on the device.
  bool hostPasses = true;
  int expectedRuns = 1;         // vk: runs of this job the caller makes (bench: warm-up + repeats)
  // cpu: called as MPU groups finish (MpuOptions::progress), from worker threads; vk streamed:
  // after each batch of brick layers.
  std::function<void(std::size_t done, std::size_t total)> progress;
  // vk sparse: a line before each long phase (vk::GpuPolygonizeOptions::phaseNote).
  std::function<void(const std::string&)> phaseNote;
  // vk sparse: after each window of the classification (vk::GpuPolygonizeOptions::classifyProgress).
  std::function<void(std::size_t done, std::size_t total)> classifyProgress;
  // cpu: mesh with this polygonizer, which keeps its scratch and MPU results for the next call
  // (bench repeats: meshing again as an editor does); null: a fresh one, freed after the call.
  std::shared_ptr<cpu::MpuPolygonizer> cpuPolygonizer;
};

struct PolygonizeStats {
  double seconds = 0.0;
  double pointEvaluations = 0.0;  // field evaluations, where the backend counts them
  // Wall seconds per phase, where the backend measures them (cpu): the MPU phase is split by the
  // CPU time its workers spent in each part (classification, field, vertices, attributes,
  // triangles), then the serial welding (prefix sums, scatter into the welded arrays).
  std::vector<std::pair<std::string, double>> phaseSeconds;
  // vk (sparse extraction): seconds per phase (device time where the queue has timestamps, and
  // `host` the rest: submits, waits, allocations, copies), bricks, device memory, submits.
  struct Phases {
    double classify = 0.0, field = 0.0, extract = 0.0, readback = 0.0, host = 0.0;
    std::uint64_t bricks = 0, activeBricks = 0, brickCells = 0, deviceBytes = 0, submits = 0, batches = 0;
    bool deviceTimed = false;
    std::uint64_t devices = 1;
    // The evaluator the batches ran ("stackless", "specialised"; empty: dense path) and, on CPU
    // drivers, the cost model's estimate for it (< 0: none).
    std::string evaluator;
    bool vertexGradient = false;
    bool vertexUniforms = false;      // the interpreted gradient read the program from uniform blocks
    bool vertexTapes = false;         // ... each vertex's brick's tape (with --brick-tapes or auto's tapes)
    bool hostClassification = false;  // the bricks classified on the host
    double modelBuild = -1.0, modelRun = -1.0;
    // extract by pass (device time): masks and edges, scans, sources, vertices, triangles
    double edges = 0.0, scans = 0.0, sources = 0.0, vertices = 0.0, triangles = 0.0;
    std::uint64_t fieldTiles = 0;  // field kernels of the sparse extraction (pruned per tile of bricks)
    std::uint64_t vertexTiles = 0;  // its vertex kernels (0: one, unpruned)
    bool generatedClassification = false;  // the bricks classified by generated code (vk/extract/classify_kernel.h)
    std::uint64_t classifyTiles = 0;  // tiles the interpreted classification ran with pruned tapes (vk/extract/classify_tiles.h)
    // Per-brick tapes (vk/extract/brick_tapes.h): instructions run per point summed over the
    // bricks, instructions stored, host seconds building them (0 without tapes).
    std::uint64_t tapeInstructions = 0, tapeWords = 0;
    double tapeSeconds = 0.0;
    double readbackDevice = 0.0;  // of `readback`: the device's copy into read-back memory (device time)
    // Where the host's wall time went (vk::HostSteps, vk/extract/polygonize.h; sparse, one device).
    struct HostSteps {
      double classification = 0.0, preparation = 0.0, fieldSubmits = 0.0, emitSubmits = 0.0, grow = 0.0, copy = 0.0,
             corners = 0.0, rowCulling = 0.0, scans = 0.0, vertexTileLists = 0.0, rows = 0.0, sources = 0.0, triangles = 0.0;
    } hostSteps;
    std::uint64_t vertexTapeWindows = 0;  // the vertex tapes' windows of uniform blocks (all batches; 0: storage buffer)
  } gpu;
};

std::vector<std::string> backendNames();     // the backends this build has
std::vector<std::string> allBackendNames();  // every name (--backend checks; vk may be absent)
std::vector<std::string> traversalNames();  // for --traversal
// The evaluator named by --traversal; throws std::invalid_argument for an unknown name. Defined
// only in Vulkan builds.
vk::Traversal traversalFromName(const std::string& name);

// Destroys the Vulkan devices the backends opened (kept for the whole process otherwise); main
// calls it before returning.
void releaseSharedDevices();

// Resolves settings.devices (vk::resolveDeviceList) without opening anything, so a bad list is
// one error line before any work; throws std::runtime_error (or nothing without --devices).
void checkDeviceList(const PolygonizeSettings& settings);

// The device the vk backend runs `settings` on (name, type, driver; json_report.h), opening it
// if needed; with --devices an array of them; an empty object in builds without Vulkan.
nlohmann::json backendDeviceJson(const PolygonizeSettings& settings);

// Waits for the kernels the vk backend's jobs left building in the background for later jobs
// (vk::Device::buildInBackground); the seconds waited (about 0 for other backends). bench calls
// it after a first run, so that its steady state runs with the kernels the first run started.
double waitForBackgroundBuilds(const PolygonizeSettings& settings);

// `recycled`: a mesh whose arrays the cpu backend, and the vk backend on one device, fill again
// (their capacity reused: vk::polygonizeInto).
mesh::TriMesh polygonize(const blobtree::Program& program, const blobtree::GridSpec& grid,
                         const PolygonizeSettings& settings, PolygonizeStats* stats = nullptr,
                         mesh::TriMesh recycled = {});

// The vk backend's sparse extraction handed to `sink` batch by batch (vk/extract/streamed_extract.h),
// the same runs as polygonize()'s mesh; one device. Throws for other backends, --devices, or in
// builds without Vulkan.
void polygonizeStreamed(const blobtree::Program& program, const blobtree::GridSpec& grid,
                        const PolygonizeSettings& settings, mesh::MeshSink& sink, PolygonizeStats* stats = nullptr);

// Options of one backend given when no selected backend uses them would do nothing: a
// UsageError naming the first ("--traversal is for the vk backend"). `backends` are the job's
// (bench may run several); options never given on `command` are not looked at.
void refuseOptionsNoBackendUses(const CLI::App& command, const std::vector<std::string>& backends);

}  // namespace blobvk::app
