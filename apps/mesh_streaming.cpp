#include "mesh_streaming.h"

#include "mesh_mpi.h"
#include "progress.h"

#include "blobvk/cpu_simd/streaming_polygonizer.h"
#include "blobvk/mesh/streamed_check.h"
#include "blobvk/mesh/streamed_writer.h"

#include <unistd.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <span>
#include <chrono>
#include <cstdlib>
#include <stdexcept>
#include <string>

namespace blobvk::app {

bool launchedByMpi() {
  return std::getenv("OMPI_COMM_WORLD_SIZE") || std::getenv("PMIX_RANK") || std::getenv("PMI_SIZE");
}

std::uint64_t estimateStreamedBytes(const blobtree::GridSpec& grid, int mpuCells) {
  const int D = mpuCells > 0 ? mpuCells : cpu::kDefaultMpuCells;
  const double cx = grid.cells.x, cy = grid.cells.y, cz = std::max(grid.cells.z, 1);
  // As estimatePolygonizeBytes: 4 x (face area in cells) crossing cells, 2 triangles and 1.5
  // vertices each (44 + 2 x 12 bytes), spread evenly over the layers; three layers are held.
  const double crossing = std::min(cx * cy * cz, 4.0 * 2.0 * (cx * cy + cy * cz + cx * cz));
  const double layers = std::ceil(cz / D);
  const double perLayer = crossing / layers * (2.0 * 12.0 + 1.5 * 44.0);
  const double mpusX = std::ceil(cx / D), mpusY = std::ceil(cy / D);
  const double rowTables = 2.0 * D * (cy + 1) * mpusX * 4.0;
  const double slots = mpusX * mpusY * layers * 8.0;
  // Streamed check: open edges of one plane and 4 bytes + 1 bit per vertex of the whole mesh.
  const double check = crossing * 1.5 * 4.2 + perLayer;
  return std::uint64_t(3.0 * perLayer + rowTables + slots + check + 16.0 * (1 << 20));
}

CLI::Validator meshResolutionRange() {
  static const int limit = [] {
    const long pages = sysconf(_SC_PHYS_PAGES), size = sysconf(_SC_PAGE_SIZE);
    const double memory = pages > 0 && size > 0 ? double(pages) * double(size) : 0.0;
    if (memory == 0) return 4096;
    int lo = 1, hi = 1 << 16;
    while (lo < hi) {
      const int mid = lo + (hi - lo + 1) / 2;
      blobtree::GridSpec g;
      g.cells = glm::ivec3(mid);
      if (double(estimateStreamedBytes(g, 0)) <= memory) lo = mid;
      else hi = mid - 1;
    }
    return lo;
  }();
  return CLI::Validator(
      [](std::string& value) -> std::string {
        long n = 0;
        try {
          std::size_t used = 0;
          n = std::stol(value, &used);
          if (used != value.size()) return "'" + value + "' is not a whole number";
        } catch (const std::exception&) {
          return "'" + value + "' is not a whole number";
        }
        if (n < 1) return "resolution " + value + " is below 1";
        if (n > limit)
          return "resolution " + value + " is above " + std::to_string(limit) +
                 ", the finest grid whose streamed meshing fits in this machine's memory";
        return {};
      },
      "RESOLUTION", "resolution");
}

namespace {
// --max-triangles while the mesh streams, and finite vertices: the job stops at the run that
// passes the limit or brings a non-finite vertex, not after the whole grid (the spooled sections
// go with the file; nothing is written).
class TriangleLimitSink final : public mesh::MeshSink {
 public:
  explicit TriangleLimitSink(std::uint64_t limit) : limit_(limit) {}
  void vertices(std::span<const mesh::Float3> positions, std::span<const mesh::Float3>, std::span<const mesh::Float3>) override {
    checkFiniteVertices(positions, vertices_);
    vertices_ += positions.size();
  }
  void triangles(std::span<const std::array<std::uint32_t, 3>> triangles, const mesh::VertexWindow&) override {
    seen_ += triangles.size();
    if (limit_ != 0 && seen_ > limit_)
      throw std::runtime_error("the mesh has more than --max-triangles " + std::to_string(limit_) + " triangles (" +
                               std::to_string(seen_) + " so far); nothing was written");
  }

 private:
  std::uint64_t limit_, seen_ = 0, vertices_ = 0;
};

// The streamed file and, when asked for, the streamed check beside it, fed by one tee.
struct StreamedOutput {
  TriangleLimitSink limit;
  mesh::StreamedMeshFile file;
  mesh::StreamedMeshCheck checker;
  mesh::TeeSink tee;
  bool check;

  static mesh::StreamedFileOptions fileOptions(const std::string& format, bool asciiPly) {
    mesh::StreamedFileOptions o;
    o.format = format;
    o.asciiPly = asciiPly;
    return o;
  }
  StreamedOutput(const std::string& out, const std::string& format, bool asciiPly, bool check, const Limits& limits)
      : limit(limits.maxTriangles),
        file(out, fileOptions(format, asciiPly)),
        tee(check ? std::vector<mesh::MeshSink*>{&limit, &file, &checker} : std::vector<mesh::MeshSink*>{&limit, &file}),
        check(check) {}

  // Counts, the triangle limit (before anything is written: the spools go with `file`), the
  // file put in place, the check's report.
  void finish(StreamedMeshResult& result, const Limits& limits) {
    result.vertices = file.vertexCount();
    result.triangles = file.triangleCount();
    checkTriangles(result.triangles, limits);
    result.bytes = file.finish();
    if (check) result.report = checker.finish();
  }
};

// The vk backend: the sparse extraction's batches of brick layers, handed on as they come back.
StreamedMeshResult meshStreamedOnDevice(const blobtree::Program& program, const blobtree::GridSpec& grid,
                                        PolygonizeSettings settings, const std::string& out, const std::string& format,
                                        bool asciiPly, bool check, const Limits& limits) {
  if (launchedByMpi())
    throw std::runtime_error("MPI ranks share the cpu backend's layers; the vk backend runs in one process (use --backend cpu under mpirun)");
  const auto start = std::chrono::steady_clock::now();
  StreamedMeshResult result;
  StreamedOutput output(out, format, asciiPly, check, limits);
  {
    Progress progress("mesh", 0);
    settings.progress = [&progress](std::size_t done, std::size_t total) { progress.update(long(done), long(total)); };
    settings.phaseNote = [](const std::string& text) { Progress::note("mesh", text); };
    settings.classifyProgress = restartingProgress("classify");
    PolygonizeStats stats;
    polygonizeStreamed(program, grid, settings, output.tee, &stats);
    result.pointEvaluations = stats.pointEvaluations;
    result.gpu = stats.gpu;
  }
  output.finish(result, limits);
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}
}  // namespace

StreamedMeshResult meshStreamed(const blobtree::Program& program, const blobtree::GridSpec& grid,
                                const PolygonizeSettings& settings, const std::string& out,
                                const std::string& format, bool asciiPly, bool check, const Limits& limits) {
  if (settings.backend != "cpu" && settings.backend != "vk")
    throw std::runtime_error("streamed meshing runs on the cpu and vk backends (not " + settings.backend + "; drop --stream)");
  if (format != "ply" && format != "obj" && format != "stl")
    throw std::runtime_error("streamed meshing writes .ply, .obj or .stl; ." + format +
                             " needs the whole mesh in memory (drop --stream or raise --max-memory)");
  if (settings.backend == "vk") return meshStreamedOnDevice(program, grid, settings, out, format, asciiPly, check, limits);
  const auto start = std::chrono::steady_clock::now();
  cpu::MpuOptions options;
  options.threads = settings.threads;
  options.refineSteps = settings.refineSteps;
  if (settings.mpuSize > 0) options.mpuCells = settings.mpuSize;

  const bool mpi = launchedByMpi();
  const MpiWorld world = mpi ? mpiStart(check) : MpiWorld{};
  StreamedMeshResult result;
  result.ranks = world.size;
  try {
    cpu::LayerPolygonizer layers(program, grid, options);
    if (world.size > 1) {  // every rank writes its own layers into the file (mesh_mpi.h)
      const MpiMeshResult r = mpiMeshLayers(world, layers, {out, StreamedOutput::fileOptions(format, asciiPly), check}, limits);
      result.vertices = r.vertices, result.triangles = r.triangles, result.bytes = r.bytes;
      result.report = r.report;
      result.pointEvaluations = double(layers.stats().pointEvaluations);  // this rank's
      result.worker = world.rank != 0;
    } else {
      StreamedOutput output(out, format, asciiPly, check, limits);
      {
        Progress progress("mesh", layers.layerCount());
        cpu::LayerJoiner join(output.tee);
        for (int z = 0; z < layers.layerCount(); ++z) {
          join.push(layers.layer(z));
          progress.update(z + 1);
        }
        join.finish();
      }
      result.pointEvaluations = double(layers.stats().pointEvaluations);
      output.finish(result, limits);
    }
  } catch (const std::exception& e) {
    if (mpi && world.size > 1) mpiAbort(e.what());  // the other ranks would wait for ever
    throw;
  }
  if (mpi) mpiStop();
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace blobvk::app
