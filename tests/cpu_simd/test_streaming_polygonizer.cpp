// The streamed (layer by layer) polygonizer against the in-memory one: the concatenated runs are
// polygonizeMpu's mesh byte for byte, and the streamed files (binary and ascii PLY, OBJ, STL) are
// the in-memory writers' files byte for byte, on several scenes, MPU sizes and thread counts,
// grids whose z size is not a multiple of the MPU size included. The streamed check must report
// what checkMesh reports, on closed meshes and on meshes cut open by the grid.
#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/scene_io.h"
#include "blobvk/cpu_simd/mpu_polygonizer.h"
#include "blobvk/cpu_simd/streaming_polygonizer.h"
#include "blobvk/mesh/checks.h"
#include "blobvk/mesh/io.h"
#include "blobvk/mesh/streamed_check.h"
#include "blobvk/mesh/streamed_writer.h"

#include <gtest/gtest.h>

#include <random>

#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

namespace {

using namespace blobvk;

const std::string kScenes = BLOBVK_SOURCE_DIR "/scenes/";

template <class T, class A, class B>
bool sameBytes(const std::vector<T, A>& a, const std::vector<T, B>& b) {
  return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0);
}

// Collects the runs back into a TriMesh, checking each triangle run's window holds its corners.
class Collect final : public mesh::MeshSink {
 public:
  mesh::TriMesh mesh;
  void vertices(std::span<const mesh::Float3> p, std::span<const mesh::Float3> n,
                std::span<const mesh::Float3> c) override {
    mesh.positions.insert(mesh.positions.end(), p.begin(), p.end());
    mesh.normals.insert(mesh.normals.end(), n.begin(), n.end());
    mesh.colours.insert(mesh.colours.end(), c.begin(), c.end());
  }
  void triangles(std::span<const std::array<std::uint32_t, 3>> t, const mesh::VertexWindow& w) override {
    for (const auto& tri : t)
      for (std::uint32_t v : tri) {
        ASSERT_GE(v, w.first);
        ASSERT_LT(v, w.first + w.a.size() + w.b.size());
        ASSERT_EQ(w[v], mesh.positions[v]);
      }
    mesh.triangles.insert(mesh.triangles.end(), t.begin(), t.end());
  }
};

std::string readAll(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

struct Case {
  std::string scene;
  int resolution, mpuCells, threads;
  friend void PrintTo(const Case& c, std::ostream* os) {
    *os << c.scene << " at " << c.resolution << ", D " << c.mpuCells << ", " << c.threads << " threads";
  }
};

blobtree::GridSpec gridOf(const blobtree::Scene& scene, const blobtree::Program& program, int resolution) {
  blobtree::GridRequest request;
  request.resolution = resolution;
  return blobtree::chooseGrid(program, scene.grid, request);
}

class StreamedMatchesInMemory : public ::testing::TestWithParam<Case> {};

TEST_P(StreamedMatchesInMemory, MeshFilesAndCheck) {
  const Case c = GetParam();
  const blobtree::Scene scene = blobtree::loadScene(kScenes + c.scene);
  const blobtree::Program program = blobtree::compile(scene.root);
  const blobtree::GridSpec grid = gridOf(scene, program, c.resolution);
  cpu::MpuOptions options;
  options.mpuCells = c.mpuCells;
  options.threads = c.threads;
  const mesh::TriMesh want = cpu::polygonizeMpu(program, grid, options);
  ASSERT_GT(want.triangleCount(), 0u);

  // The runs, and the edge keys of the layers, concatenated.
  {
    cpu::LayerPolygonizer layers(program, grid, options);
    Collect collect;
    cpu::LayerJoiner join(collect);
    std::vector<std::uint64_t> keys;
    for (int z = 0; z < layers.layerCount(); ++z) {
      cpu::MeshLayer layer = layers.layer(z);
      keys.insert(keys.end(), layer.keys.begin(), layer.keys.end());
      join.push(std::move(layer));
    }
    join.finish();
    EXPECT_TRUE(sameBytes(collect.mesh.positions, want.positions)) << "positions";
    EXPECT_TRUE(sameBytes(collect.mesh.normals, want.normals)) << "normals";
    EXPECT_TRUE(sameBytes(collect.mesh.colours, want.colours)) << "colours";
    EXPECT_TRUE(sameBytes(collect.mesh.triangles, want.triangles)) << "triangles";
    EXPECT_TRUE(sameBytes(keys, want.edgeKeys)) << "edge keys";
    EXPECT_EQ(join.vertices(), want.vertexCount());
    EXPECT_EQ(join.triangles(), want.triangleCount());
  }

  // The files, through polygonizeMpuStreamed with a streamed check beside each writer.
  const std::filesystem::path dir = std::filesystem::temp_directory_path() /
                                    ("blobvk_stream_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const mesh::MeshReport wantReport = mesh::checkMesh(want);
  struct Format {
    std::string ext;
    bool ascii;
    std::string bytes;
  };
  const Format formats[] = {{"ply", false, mesh::encodePly(want, true)},
                            {"ply", true, mesh::encodePly(want, false)},
                            {"obj", false, mesh::encodeObj(want)},
                            {"stl", false, mesh::encodeStl(want)}};
  for (const Format& f : formats) {
    const std::string path = (dir / ("out." + f.ext)).string();
    mesh::StreamedFileOptions fo;
    fo.format = f.ext;
    fo.asciiPly = f.ascii;
    if (f.ext != "stl") fo.copyPieceBytes = 1000;  // many pieces, copied on several threads
    mesh::StreamedMeshFile file(path, fo);
    mesh::StreamedMeshCheck check;
    mesh::TeeSink tee({&file, &check});
    cpu::polygonizeMpuStreamed(program, grid, options, tee);
    EXPECT_EQ(file.finish(), f.bytes.size());
    EXPECT_TRUE(readAll(path) == f.bytes) << f.ext << (f.ascii ? " ascii" : "") << ": bytes differ";
    const mesh::MeshReport got = check.finish();
    EXPECT_EQ(got.summary(), wantReport.summary());
    EXPECT_EQ(got.volume, wantReport.volume);
    EXPECT_TRUE(got.watertight()) << got.summary();
  }
  // Nothing but the outputs is left beside them (spools are unlinked, temporaries renamed).
  std::size_t entries = 0;
  for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator(dir)) ++entries;
  EXPECT_EQ(entries, 3u);
  std::filesystem::remove_all(dir);
}

// Layer count vs z size: "z % D" cases are those whose top layer is thinner than D.
INSTANTIATE_TEST_SUITE_P(Scenes, StreamedMatchesInMemory,
                         ::testing::Values(Case{"tower.json", 50, 16, 1}, Case{"tower.json", 50, 16, 2},
                                           Case{"tower_L6P8I4.json", 70, 8, 2},
                                           Case{"eggshell.json", 45, 4, 3},
                                           Case{"twisted_column.json", 37, 6, 2},
                                           Case{"random128.json", 40, 5, 1},
                                           Case{"creature.json", 33, 16, 2}));

TEST(StreamedPolygonizer, CasesIncludeTopLayersThinnerThanAnMpu) {
  int thin = 0;
  for (const auto& [scene, res, D] : {std::tuple{"tower.json", 50, 16}, std::tuple{"eggshell.json", 45, 4},
                                       std::tuple{"twisted_column.json", 37, 6}, std::tuple{"random128.json", 40, 5}}) {
    const blobtree::Scene s = blobtree::loadScene(kScenes + scene);
    thin += gridOf(s, blobtree::compile(s.root), res).cells.z % D != 0;
  }
  EXPECT_GE(thin, 2);
}

// A grid that cuts the surface leaves it open: the streamed check must see the same boundary.
TEST(StreamedCheck, ReportsOpenMeshesAsCheckMeshDoes) {
  const blobtree::Scene scene = blobtree::loadScene(kScenes + "tower.json");
  const blobtree::Program program = blobtree::compile(scene.root);
  blobtree::GridSpec grid = gridOf(scene, program, 40);
  grid.cells.z = grid.cells.z / 2 + 3;  // the top half is cut off
  grid.cells.x = grid.cells.x * 2 / 3;
  cpu::MpuOptions options;
  options.mpuCells = 8;
  const mesh::TriMesh want = cpu::polygonizeMpu(program, grid, options);
  const mesh::MeshReport wantReport = mesh::checkMesh(want);
  ASSERT_GT(wantReport.boundaryEdges, 0u);
  mesh::StreamedMeshCheck check;
  cpu::polygonizeMpuStreamed(program, grid, options, check);
  const mesh::MeshReport got = check.finish();
  EXPECT_EQ(got.summary(), wantReport.summary());
  EXPECT_FALSE(got.watertight());
}

TEST(StreamedCheck, FindsMisorientedAndNonManifoldEdges) {
  // Two triangles of a tetrahedron's four, one flipped, plus a third on the shared edge.
  const std::vector<mesh::Float3> p{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 1}};
  const std::vector<std::array<std::uint32_t, 3>> t{{0, 1, 2}, {0, 1, 3}, {1, 0, 4}};
  mesh::TriMesh m;
  m.positions.assign(p.begin(), p.end()), m.triangles.assign(t.begin(), t.end());
  mesh::StreamedMeshCheck check;
  check.vertices(p, {}, {});
  mesh::VertexWindow w;
  w.a = p;
  check.triangles(t, w);
  const mesh::MeshReport got = check.finish(), want = mesh::checkMesh(m);
  EXPECT_EQ(got.summary(), want.summary());
  EXPECT_EQ(got.nonManifoldEdges, 1u);
}

// Random triangle soups over blocks of vertices, streamed as the polygonizer streams them: run k
// uses blocks k and k + 1 (window: block k, then k + 1). Duplicated, flipped, degenerate and fan
// triangles (a vertex of valence ~60: a large bucket of the check's sort), and runs whose lower
// vertices spread thin (the check's plain-sort path), all judged as checkMesh judges them.
TEST(StreamedCheck, MatchesCheckMeshOnRandomSoupsStreamedInRuns) {
  for (std::uint32_t seed = 1; seed <= 20; ++seed) {
    std::mt19937 rng(seed);
    // Small dense runs, large dense runs, and few triangles over many vertices (spread thin).
    const std::uint32_t blocks = 4 + seed % 3, perBlock = seed % 3 == 0 ? 40 : seed % 3 == 1 ? 3000 : 20000;
    const std::uint32_t perRun = perBlock == 20000 ? 100 : perBlock;
    std::vector<mesh::Float3> p(std::size_t(blocks) * perBlock);
    std::uniform_real_distribution<float> coord(-1.0f, 1.0f);
    for (auto& v : p) v = {coord(rng), coord(rng), coord(rng)};
    mesh::TriMesh m;
    m.positions.assign(p.begin(), p.end());
    std::vector<std::vector<std::array<std::uint32_t, 3>>> runs(blocks);
    for (std::uint32_t k = 0; k < blocks; ++k) {
      const std::uint32_t lo = k * perBlock, span = (k + 1 < blocks ? 2 : 1) * perBlock;
      std::uniform_int_distribution<std::uint32_t> pick(lo, lo + span - 1);
      auto& run = runs[k];
      for (std::uint32_t i = 0; i < perRun; ++i) {
        std::array<std::uint32_t, 3> t{pick(rng), pick(rng), pick(rng)};
        run.push_back(t);
        if (i % 7 == 0) run.push_back({t[1], t[0], t[2]});  // the same edges, flipped
        if (i % 11 == 0) run.push_back(t);                   // a duplicate
        if (i % 13 == 0) run.push_back({t[0], t[0], t[1]});  // degenerate
      }
      for (std::uint32_t i = 0; i < 60; ++i) run.push_back({lo, pick(rng), pick(rng)});  // a fan at lo
      m.triangles.insert(m.triangles.end(), run.begin(), run.end());
    }
    mesh::StreamedMeshCheck check;
    check.vertices(std::span(p).subspan(0, perBlock), {}, {});
    for (std::uint32_t k = 0; k < blocks; ++k) {
      if (k + 1 < blocks) check.vertices(std::span(p).subspan(std::size_t(k + 1) * perBlock, perBlock), {}, {});
      mesh::VertexWindow w;
      w.first = std::uint64_t(k) * perBlock;
      w.a = std::span(p).subspan(std::size_t(k) * perBlock, perBlock);
      if (k + 1 < blocks) w.b = std::span(p).subspan(std::size_t(k + 1) * perBlock, perBlock);
      check.triangles(runs[k], w);
    }
    const mesh::MeshReport got = check.finish(), want = mesh::checkMesh(m);
    EXPECT_EQ(got.edges, want.edges) << "seed " << seed;
    EXPECT_EQ(got.boundaryEdges, want.boundaryEdges) << "seed " << seed;
    EXPECT_EQ(got.nonManifoldEdges, want.nonManifoldEdges) << "seed " << seed;
    EXPECT_EQ(got.misorientedEdges, want.misorientedEdges) << "seed " << seed;
    EXPECT_EQ(got.degenerateTriangles, want.degenerateTriangles) << "seed " << seed;
    EXPECT_EQ(got.unreferencedVertices, want.unreferencedVertices) << "seed " << seed;
    EXPECT_EQ(got.eulerCharacteristic, want.eulerCharacteristic) << "seed " << seed;
    EXPECT_GT(got.nonManifoldEdges + got.misorientedEdges, 0u) << "seed " << seed;
  }
}

TEST(StreamedWriter, UnknownFormatAndUnwritableDirectoryAreClearErrors) {
  mesh::StreamedFileOptions fo;
  fo.format = "gltf";
  EXPECT_THROW(mesh::StreamedMeshFile("/tmp/x.gltf", fo), std::invalid_argument);
  fo.format = "ply";
  try {
    mesh::StreamedMeshFile file("/nonexistent-dir/out.ply", fo);
    FAIL() << "no error for a missing directory";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent-dir"), std::string::npos) << e.what();
  }
}

}  // namespace
