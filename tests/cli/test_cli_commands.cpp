// Every command once, as a user runs it, with its output checked by an independent reader:
// meshes by the mesh checks on the PLY read back, images decoded by libpng, JSON parsed and
// compared with counts taken from the files themselves.
#include "cli_files.h"
#include "run_cli.h"

#include "blobvk/mesh/checks.h"
#include "blobvk/mesh/io.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

namespace {

using namespace blobvk::testing;
namespace fs = std::filesystem;

fs::path dir(const std::string& name) {
  const fs::path d = scratchDir() / name;
  fs::create_directories(d);
  return d;
}

const std::string tower = sourcePath("scenes/tower.json");

class CliCommands : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { setenv("LP_NUM_THREADS", "2", 0); }
};

// `generate random --ricci N` joins the same points with a Ricci blend of power N: the scene
// file says so, and its field is (sum f^N)^(1/N) of the plain blend's children, so at N = 1 both
// scenes mesh alike and at N = 8 the Ricci blend's surface lies inside the blend's.
TEST_F(CliCommands, GenerateRandomRicciJoinsThePointsWithARicciBlend) {
  const fs::path cwd = dir("ricci");
  ASSERT_EQ(runCliSplit("generate random --count 12 --seed 4 -o plain.json", cwd).status, 0);
  ASSERT_EQ(runCliSplit("generate random --count 12 --seed 4 --ricci 8 -o ricci.json", cwd).status, 0);
  const nlohmann::json plain = nlohmann::json::parse(std::ifstream(cwd / "plain.json"));
  const nlohmann::json ricci = nlohmann::json::parse(std::ifstream(cwd / "ricci.json"));
  EXPECT_EQ(plain["root"]["type"], "blend");
  EXPECT_EQ(ricci["root"]["type"], "ricci");
  EXPECT_EQ(ricci["root"]["power"], 8.0);
  EXPECT_EQ(plain["root"]["children"], ricci["root"]["children"]);
  auto volume = [&](const std::string& scene) {
    const CliSplitRun r = runCliSplit("mesh " + scene + " --resolution 40 -q --json -o m.ply", cwd);
    EXPECT_EQ(r.status, 0) << r.err;
    return nlohmann::json::parse(r.out)["check"]["volume"].get<double>();
  };
  EXPECT_LT(volume("ricci.json"), 0.95 * volume("plain.json"));
  const CliSplitRun bad = runCliSplit("generate random --ricci 0 -o r.json", cwd);
  EXPECT_NE(bad.status, 0);
  EXPECT_NE(bad.err.find("--ricci"), std::string::npos) << bad.err;
}

TEST_F(CliCommands, InfoJsonCountsWhatTheFileHolds) {
  const fs::path cwd = dir("info");
  ASSERT_EQ(runCliSplit("generate random --count 7 --seed 3 -o r.json", cwd).status, 0);
  const CliSplitRun r = runCliSplit("info r.json --json", cwd);
  ASSERT_EQ(r.status, 0) << r.err;
  const nlohmann::json info = nlohmann::json::parse(r.out);
  EXPECT_EQ(info["blobvk_version"], BLOBVK_VERSION);
  EXPECT_EQ(info["nodes"]["primitives"], 7);
  EXPECT_EQ(info["program"]["primitives"], 7);
  EXPECT_GT(info["program"]["instructions"].get<int>(), 7);
  const auto lo = info["bounds"]["lo"], hi = info["bounds"]["hi"];
  for (int a = 0; a < 3; ++a) EXPECT_LT(lo[a].get<double>(), hi[a].get<double>());
  const CliSplitRun text = runCliSplit("info r.json", cwd);
  EXPECT_NE(text.out.find("7 primitives"), std::string::npos) << text.out;
}

TEST_F(CliCommands, GenerateWritesScenesThatLoad) {
  const fs::path cwd = dir("generate");
  for (const std::string& kind : std::vector<std::string>{"tower --levels 2 --pillars 4", "eggshell", "random --count 5"}) {
    const CliSplitRun r = runCliSplit("generate " + kind + " -o g.json", cwd);
    ASSERT_EQ(r.status, 0) << kind << r.err;
    const nlohmann::json scene = nlohmann::json::parse(fileBytes(cwd / "g.json"));
    const nlohmann::json info = nlohmann::json::parse(runCliSplit("info g.json --json", cwd).out);
    EXPECT_EQ(info["nodes"]["primitives"].get<std::size_t>(), countJsonPrimitives(scene["root"])) << kind;
  }
  // A tower over the readers' 4,000,000 nodes is refused before it is built, and no file is left.
  const CliSplitRun big = runCliSplit("generate tower --levels 1000 --pillars 1000 -o big.json", cwd);
  EXPECT_EQ(big.status, 2) << big.err;
  EXPECT_NE(big.err.find("the tower would have 5002001 nodes"), std::string::npos) << big.err;
  EXPECT_FALSE(fs::exists(cwd / "big.json"));
  // Options in range that place a node past the readers' coordinate limit (10^6): refused, with
  // the reader's reason, and no file a later command could not open.
  const CliSplitRun far = runCliSplit("generate tower --levels 101 --pillars 3 --height 10000 -o far.json", cwd);
  EXPECT_EQ(far.status, 2) << far.err;
  EXPECT_NE(far.err.find("the scene would not load"), std::string::npos) << far.err;
  EXPECT_NE(far.err.find("is out of range"), std::string::npos) << far.err;
  EXPECT_FALSE(fs::exists(cwd / "far.json"));
}

// A grid the scene sets too fine is refused with the scene's key as the place (the options name
// themselves), before any work: too many cells, or more memory than the machine has.
TEST_F(CliCommands, AGridTooFineNamesTheScenesKey) {
  const fs::path cwd = dir("grid_key");
  nlohmann::json scene = nlohmann::json::parse(fileBytes(sourcePath("scenes/eggshell.json")));
  scene["grid"] = {{"cellSize", 1e-6}};
  std::ofstream(cwd / "fine.json") << scene.dump();
  CliSplitRun r = runCliSplit("info fine.json", cwd);
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_NE(r.err.find("fine.json: /grid/cellSize: grid of "), std::string::npos) << r.err;
  scene["grid"] = {{"resolution", 16384}};
  std::ofstream(cwd / "big.json") << scene.dump();
  r = runCliSplit("mesh big.json -o big.ply --max-memory 1G", cwd);
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_NE(r.err.find("big.json: /grid/resolution: "), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("--max-memory"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(cwd / "big.ply"));
  // An empty model's grid is not at fault: no key named.
  std::ofstream(cwd / "empty.json") << R"({"blobvk":1,"grid":{"resolution":64},"root":{"type":"intersection",)"
                                       R"("children":[{"type":"point"},{"type":"point","centre":[10,0,0]}]}})";
  r = runCliSplit("mesh empty.json -o e.ply", cwd);
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_NE(r.err.find("empty.json: the model is empty"), std::string::npos) << r.err;
  // Given on the command line, the option is the place, not the scene's key.
  r = runCliSplit("mesh big.json -o big.ply --resolution 2048 --max-memory 1M", cwd);
  EXPECT_NE(r.status, 0) << r.err;
  EXPECT_EQ(r.err.find("/grid/resolution"), std::string::npos) << r.err;
}

// simulate and cut write a folder of frames: an existing file there is named as such.
TEST_F(CliCommands, AFileWhereTheFramesGoIsNamed) {
  const fs::path cwd = dir("frames_file");
  std::ofstream(cwd / "taken") << "x";
  const CliSplitRun r = runCliSplit("simulate " + sourcePath("scenes/soft_peanut.json") + " -o taken --steps 1 --no-png", cwd);
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_NE(r.err.find("taken: exists and is not a folder"), std::string::npos) << r.err;
  EXPECT_EQ(fileBytes(cwd / "taken"), "x");
}

// convert keeps the model: the legacy file and its JSON mesh to the same bytes.
TEST_F(CliCommands, ConvertKeepsTheModel) {
  const fs::path cwd = dir("convert");
  const std::string blob = sourcePath("scenes/legacy/peanut.blob");
  CliSplitRun r = runCliSplit("convert " + blob + " p.json", cwd);
  ASSERT_EQ(r.status, 0) << r.err;
  ASSERT_EQ(runCliSplit("mesh " + blob + " -o a.ply --resolution 40 -q", cwd).status, 0);
  ASSERT_EQ(runCliSplit("mesh p.json -o b.ply --resolution 40 -q", cwd).status, 0);
  EXPECT_EQ(fileBytes(cwd / "a.ply"), fileBytes(cwd / "b.ply"));
  EXPECT_TRUE(blobvk::mesh::checkMesh(blobvk::mesh::readPly((cwd / "b.ply").string())).watertight());
}

TEST_F(CliCommands, MeshJsonMatchesTheFileWritten) {
  const fs::path cwd = dir("mesh_json");
  const CliSplitRun r = runCliSplit("mesh " + tower + " -o t.ply --resolution 40 --json", cwd);
  ASSERT_EQ(r.status, 0) << r.err;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  const blobvk::mesh::TriMesh mesh = blobvk::mesh::readPly((cwd / "t.ply").string());
  EXPECT_EQ(j["blobvk_version"], BLOBVK_VERSION);
  EXPECT_EQ(j["triangles"].get<std::size_t>(), mesh.triangleCount());
  EXPECT_EQ(j["vertices"].get<std::size_t>(), mesh.vertexCount());
  EXPECT_EQ(j["bytes"].get<std::size_t>(), fs::file_size(cwd / "t.ply"));
  EXPECT_EQ(j["check"]["watertight"], blobvk::mesh::checkMesh(mesh).watertight());
  EXPECT_EQ(j["grid"]["cells"][0].get<int>() > 0, true);
}

// --simplify: the PLY read back has the requested share of the plain run's triangles and is still
// watertight, and the check line says so; .glb is a GLB container whose header length is the file's.
TEST_F(CliCommands, MeshSimplifiesAndWritesGlb) {
  const fs::path cwd = dir("mesh_simplify");
  ASSERT_EQ(runCliSplit("mesh " + tower + " -o plain.ply --resolution 48 -q", cwd).status, 0);
  CliSplitRun r = runCliSplit("mesh " + tower + " -o quarter.ply --resolution 48 --simplify 0.25", cwd);
  ASSERT_EQ(r.status, 0) << r.err;
  const blobvk::mesh::TriMesh plain = blobvk::mesh::readPly((cwd / "plain.ply").string());
  const blobvk::mesh::TriMesh quarter = blobvk::mesh::readPly((cwd / "quarter.ply").string());
  EXPECT_NEAR(double(quarter.triangleCount()) / double(plain.triangleCount()), 0.25, 0.01);
  EXPECT_TRUE(blobvk::mesh::checkMesh(quarter).watertight());
  EXPECT_NE(r.out.find("simplified " + std::to_string(plain.triangleCount()) + " -> " +
                       std::to_string(quarter.triangleCount()) + " triangles"),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("still watertight"), std::string::npos) << r.out;

  r = runCliSplit("mesh " + tower + " -o t.glb --resolution 48", cwd);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("vertex order: ACMR"), std::string::npos) << "glTF output is GPU-ordered by default: " << r.out;
  const std::string glb = fileBytes(cwd / "t.glb");
  ASSERT_GE(glb.size(), 20u);
  EXPECT_EQ(glb.substr(0, 4), "glTF");
  std::uint32_t length = 0;
  std::memcpy(&length, glb.data() + 8, 4);
  EXPECT_EQ(length, glb.size());
  EXPECT_EQ(runCliSplit("mesh " + tower + " -o x.ply --simplify 1.5", cwd).status, 2);

  // An error bound that collapses the die to nothing backs off to a handful of triangles (it once
  // kept half the mesh), and both the JSON and the check line say it backed off.
  const std::string dice = sourcePath("scenes/dice.json");
  r = runCliSplit("mesh " + dice + " -o d.ply --resolution 48 --simplify 99% --json", cwd);
  ASSERT_EQ(r.status, 0) << r.err;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_TRUE(j["simplify"]["backed_off"].get<bool>()) << r.out;
  EXPECT_TRUE(j["simplify"]["watertight_after"].get<bool>()) << r.out;
  EXPECT_LT(j["triangles"].get<std::size_t>(), 100u) << r.out;
  r = runCliSplit("mesh " + dice + " -o d.ply --resolution 48 --simplify 99%", cwd);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("still watertight (backed off: "), std::string::npos) << r.out;
  EXPECT_EQ(runCliSplit("mesh " + tower + " -o x.glb --optimize --no-optimize", cwd).status, 2);
}

// bench's counts are the mesh's: the triangles of a `mesh` run at the same resolution.
TEST_F(CliCommands, BenchJsonReportsTheMeshItTimed) {
  const fs::path cwd = dir("bench");
  CliSplitRun r = runCliSplit("bench " + tower + " --resolution 32 --repeats 2 --warmup 0 --backend cpu reference --json", cwd);
  ASSERT_EQ(r.status, 0) << r.err;
  const nlohmann::json rows = nlohmann::json::parse(r.out);
  ASSERT_EQ(rows.size(), 2u);
  ASSERT_EQ(runCliSplit("mesh " + tower + " -o t.ply --resolution 32 -q", cwd).status, 0);
  const std::size_t triangles = blobvk::mesh::readPly((cwd / "t.ply").string()).triangleCount();
  for (const auto& row : rows) {
    EXPECT_EQ(row["triangles"].get<std::size_t>(), triangles) << row.dump();
    EXPECT_GT(row["median_s"].get<double>(), 0.0);
    EXPECT_LE(row["min_s"].get<double>(), row["max_s"].get<double>());
    EXPECT_GE(row["background_build_wait_s"].get<double>(), 0.0);  // vk's untimed wait; ~0 here
  }
  EXPECT_NE(r.err.find("bench 100% (2/2)"), std::string::npos) << r.err;
  r = runCliSplit("bench " + tower + " --resolution 16 --repeats 1", cwd);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("median s"), std::string::npos) << r.out;
}

// A legacy file has no grid section, so one with a bend (an unbounded model) is meshed with
// --bounds: the same bytes as its JSON conversion with those bounds as grid.bounds. --bounds also
// meshes a region of a bounded model: no vertex outside it. Bad bounds are usage errors.
TEST_F(CliCommands, BoundsOnTheCommandLineMeshAnUnboundedLegacyFileAndARegion) {
  const fs::path cwd = dir("bounds");
  std::ofstream(cwd / "bend.blob") << "[BLOBNODE 0]\nIsOperator=1\nOperatorType=BEND\nrate=0.3\ncenter=0\n"
                                      "left bound=-1\nright bound=3\nChildrenIDs=(1)\n\n[BLOBNODE 1]\nIsOperator=0\n"
                                      "PrimitiveType=LINE\nstart=(0, -1, 0)\nend=(0, 3, 0)\n\n[Global]\nFileVersion=6\nRootIDs=(0)\n";
  CliSplitRun r = runCliSplit("mesh bend.blob -o none.ply", cwd);
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.err.find("the model is unbounded"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("or --bounds x0,y0,z0,x1,y1,z1"), std::string::npos) << r.err;
  r = runCliSplit("mesh bend.blob -o bounded.ply --resolution 40 --bounds -3,-3,-4,3,5,4", cwd);
  ASSERT_EQ(r.status, 0) << r.err;
  ASSERT_EQ(runCliSplit("convert bend.blob bend.json", cwd).status, 0);
  nlohmann::json scene = nlohmann::json::parse(fileBytes(cwd / "bend.json"));
  scene["grid"] = {{"bounds", {{"lo", {-3, -3, -4}}, {"hi", {3, 5, 4}}}}};
  std::ofstream(cwd / "bend_bounded.json") << scene.dump();
  ASSERT_EQ(runCliSplit("mesh bend_bounded.json -o json.ply --resolution 40", cwd).status, 0);
  EXPECT_GT(fileBytes(cwd / "json.ply").size(), 1000u);
  EXPECT_EQ(fileBytes(cwd / "bounded.ply"), fileBytes(cwd / "json.ply"));

  ASSERT_EQ(runCliSplit("mesh " + tower + " -o half.ply --resolution 48 --bounds -10,-10,-10,0,30,10", cwd).status, 0);
  const blobvk::mesh::TriMesh half = blobvk::mesh::readPly((cwd / "half.ply").string());
  ASSERT_GT(half.triangleCount(), 100u);
  // The grid spans the bounds with a cell of margin each side, rounded up to whole cells.
  const float cell = 40.0f / 48.0f;
  float maxX = -1e9f;
  for (const auto& p : half.positions) maxX = std::max(maxX, p.x);
  EXPECT_LE(maxX, 2.0f * cell + 1e-3f);
  EXPECT_GT(maxX, -cell);

  for (const std::string bad : {"1,2,3", "0,0,0,1,1,nan", "0,0,0,1,1,1,1", "0,0,5,1,1,1", "0,0,0,2e6,1,1"}) {
    r = runCliSplit("mesh " + tower + " -o x.ply --bounds " + bad, cwd);
    EXPECT_EQ(r.status, 2) << bad << ": " << r.err;
    EXPECT_NE(r.err.find("--bounds"), std::string::npos) << r.err;
  }
  EXPECT_FALSE(fs::exists(cwd / "x.ply"));
}

// TetGen segfaults in its own clean-up on the remeshed surface of the eggshell at 24 cells (35
// closed pieces): it runs in a child process, so the command warns, meshes the raw surface and
// carries on instead of dying with the signal.
TEST_F(CliCommands, ATetgenCrashIsAWarningNotACrash) {
  const fs::path cwd = dir("tetgen_crash");
  const CliSplitRun r = runCliSplit("simulate " + sourcePath("scenes/eggshell_sim.json") + " -o f --steps 1 --resolution 24 --no-png", cwd);
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.err.find("TetGen crashed on this surface"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("meshing the raw surface"), std::string::npos) << r.err;
  EXPECT_TRUE(fs::exists(cwd / "f" / "frame_00001.ply"));
}

#ifdef BLOBVK_HAVE_VULKAN
TEST_F(CliCommands, DevicesListsLavapipeWithItsDriver) {
  const fs::path cwd = dir("devices");
  CliSplitRun r = runCliSplit("devices --json", cwd);
  ASSERT_EQ(r.status, 0) << r.err;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["blobvk_version"], BLOBVK_VERSION);
  bool lavapipe = false;
  for (const auto& d : j["devices"]) {
    if (d["name"].get<std::string>().find("llvmpipe") == std::string::npos) continue;
    lavapipe = true;
    EXPECT_EQ(d["type"], "CPU");
    EXPECT_EQ(d["driver_name"], "llvmpipe");
    EXPECT_NE(d["driver_info"].get<std::string>().find("Mesa"), std::string::npos) << d.dump();
    EXPECT_GE(d["limits"]["max_storage_buffer_range"].get<std::uint64_t>(), 1u << 27);
    // lavapipe's memory is the host's: one device-local heap whose one type the host maps, cached.
    ASSERT_GE(d["memory_heaps"].size(), 1u) << d.dump();
    const auto& heap = d["memory_heaps"][0];
    EXPECT_TRUE(heap["device_local"].get<bool>());
    EXPECT_GT(heap["bytes"].get<std::uint64_t>(), 0u);
    ASSERT_GE(heap["types"].size(), 1u);
    EXPECT_EQ(heap["types"][0]["flags"],
              nlohmann::json({"device-local", "host-visible", "host-coherent", "host-cached"}));
  }
  EXPECT_TRUE(lavapipe) << r.out;
  r = runCliSplit("devices", cwd);
  ASSERT_EQ(r.status, 0);
  EXPECT_NE(r.out.find("[0] "), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("llvmpipe"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("heap 0: "), std::string::npos) << r.out;
}

// The vk backend on lavapipe writes the CPU backend's bytes (vertices ordered by edge key).
TEST_F(CliCommands, MeshOnTheVulkanBackendEqualsTheCpuMesh) {
  const fs::path cwd = dir("mesh_vk");
  CliSplitRun r = runCliSplit("mesh " + tower + " -o vk.ply --resolution 48 --backend vk --validation --json", cwd);
  ASSERT_EQ(r.status, 0) << r.err;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_NE(j["device"]["name"].get<std::string>().find("llvmpipe"), std::string::npos) << r.out;
  EXPECT_EQ(j["device"]["driver_name"], "llvmpipe");
  ASSERT_EQ(runCliSplit("mesh " + tower + " -o cpu.ply --resolution 48 -q", cwd).status, 0);
  const auto report = blobvk::mesh::checkMesh(blobvk::mesh::readPly((cwd / "vk.ply").string()));
  EXPECT_TRUE(report.watertight()) << report.summary();
  EXPECT_GT(report.triangles, 1000u);
  EXPECT_EQ(fileBytes(cwd / "vk.ply"), fileBytes(cwd / "cpu.ply"));
}

// point_evaluations counts what the CPU backend's counts: the grid samples the field pass takes
// (fewer than the active bricks' points with row culling, all with --no-row-culling), then
// per vertex its refinement steps and its attribute pass (one analytic-gradient pass; six
// central-difference samples and a colour pass with the stack-based traversal), in memory and
// streamed alike. The oracle: the bricks' points and the vertices the same report gives.
TEST_F(CliCommands, VulkanEvaluationsCountEveryVertexSample) {
  const fs::path cwd = dir("mesh_vk_evaluations");
  auto report = [&](const std::string& options, const std::string& file = "e.ply") {
    const CliSplitRun r = runCliSplit("mesh " + tower + " -o " + file + " --resolution 48 --backend vk --json " + options, cwd);
    EXPECT_EQ(r.status, 0) << options << r.err;
    return nlohmann::json::parse(r.out);
  };
  const nlohmann::json plain = report("", "plain.ply");
  const double vertices = plain["vertices"].get<double>();
  ASSERT_GT(vertices, 1000.0);
  const double side = plain["gpu"]["brick_cells"].get<double>() + 1.0;
  const double gridSamples = plain["point_evaluations"].get<double>() - vertices;
  EXPECT_LE(gridSamples, plain["gpu"]["active_bricks"].get<double>() * side * side * side);
  EXPECT_EQ(report("--refine 2")["point_evaluations"].get<double>(), gridSamples + 3.0 * vertices);
  EXPECT_EQ(report("--traversal stack")["point_evaluations"].get<double>(), gridSamples + 7.0 * vertices);
  EXPECT_EQ(report("--stream")["point_evaluations"].get<double>(), gridSamples + vertices);
  // Without row culling every point of an active brick is a sample, and the mesh is the same bytes.
  const nlohmann::json every = report("--no-row-culling", "every.ply");
  EXPECT_EQ(every["point_evaluations"].get<double>(),
            every["gpu"]["active_bricks"].get<double>() * side * side * side + vertices);
  EXPECT_EQ(fileBytes(cwd / "plain.ply"), fileBytes(cwd / "every.ply"));
  const CliSplitRun all = runCliSplit("bench " + tower + " --resolution 48 --backend vk --repeats 1 --no-row-culling --json", cwd);
  ASSERT_EQ(all.status, 0) << all.err;
  const nlohmann::json b = nlohmann::json::parse(all.out)[0];
  EXPECT_EQ(b["point_evaluations"].get<double>(),
            b["vk_phases"]["active_bricks"].get<double>() * side * side * side + b["vertices"].get<double>());
}

// --device-passes: on a CPU device the bookkeeping passes (row counts, sources, triangles...) run
// as kernels on the device instead of on the host; the same bytes either way, and bench's host
// steps say where they ran. The cpu backend refuses the option.
TEST_F(CliCommands, DevicePassesWriteTheBytesOfTheHostPasses) {
  const fs::path cwd = dir("mesh_device_passes");
  const std::string base = "mesh " + tower + " --resolution 48 --backend vk -q ";
  ASSERT_EQ(runCliSplit(base + "-o host.ply", cwd).status, 0);
  ASSERT_EQ(runCliSplit(base + "-o device.ply --device-passes", cwd).status, 0);
  EXPECT_EQ(fileBytes(cwd / "host.ply"), fileBytes(cwd / "device.ply"));
  auto bench = [&](const std::string& options) {
    const CliSplitRun r = runCliSplit("bench " + tower + " --resolution 48 --backend vk --repeats 1 --json " + options, cwd);
    EXPECT_EQ(r.status, 0) << r.err;
    return nlohmann::json::parse(r.out)[0];
  };
  const nlohmann::json host = bench(""), device = bench("--device-passes");
  EXPECT_EQ(device["vk_phases"]["host_steps"]["sources"].get<double>(), 0.0);
  EXPECT_EQ(device["vk_phases"]["host_steps"]["triangles"].get<double>(), 0.0);
  if (host["device"]["type"] == "CPU") {
    EXPECT_GT(host["vk_phases"]["host_steps"]["rows"].get<double>(), 0.0);
    EXPECT_GT(host["vk_phases"]["host_steps"]["sources"].get<double>(), 0.0);
    EXPECT_GT(host["vk_phases"]["host_steps"]["triangles"].get<double>(), 0.0);
  }
  EXPECT_EQ(host["triangles"], device["triangles"]);
  const CliSplitRun cpu = runCliSplit("mesh " + tower + " -o cpu.ply --device-passes", cwd);
  EXPECT_NE(cpu.status, 0);
  EXPECT_NE(cpu.err.find("--device-passes is for the vk backend"), std::string::npos) << cpu.err;
}

// --devices: lavapipe opened two and three times shares the brick batches and writes the bytes
// of one device (and of the CPU backend); a bad list is one error line naming the entry, before
// any work and with no file written.
TEST_F(CliCommands, MeshOnSeveralDevicesWritesTheOneDeviceBytes) {
  const fs::path cwd = dir("mesh_devices");
  const std::string base = "mesh " + tower + " --resolution 64 ";
  ASSERT_EQ(runCliSplit(base + "-o one.ply --backend vk --device 0 -q", cwd).status, 0);
  ASSERT_EQ(runCliSplit(base + "-o cpu.ply -q", cwd).status, 0);
  CliSplitRun r = runCliSplit(base + "-o two.ply --backend vk --devices 0,0 --validation --json", cwd);
  ASSERT_EQ(r.status, 0) << r.err;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  ASSERT_EQ(j["devices"].size(), 2u) << r.out;
  EXPECT_EQ(j["devices"][1]["driver_name"], "llvmpipe");
  EXPECT_EQ(j["gpu"]["devices"], 2);
  EXPECT_GE(j["gpu"]["batches"].get<int>(), 2) << r.out;
  ASSERT_EQ(runCliSplit(base + "-o three.ply --backend vk --devices llvmpipe,0,0 -q", cwd).status, 0);
  // The CPU polygonizer as one more worker, beside one device and beside two.
  r = runCliSplit(base + "-o cpuw.ply --backend vk --cpu-worker --validation -q", cwd);
  ASSERT_EQ(r.status, 0) << r.err;
  ASSERT_EQ(runCliSplit(base + "-o cpuw2.ply --backend vk --devices 0,0 --cpu-worker -q", cwd).status, 0);
  const std::string one = fileBytes(cwd / "one.ply");
  EXPECT_GT(one.size(), 10000u);
  EXPECT_EQ(fileBytes(cwd / "two.ply"), one);
  EXPECT_EQ(fileBytes(cwd / "three.ply"), one);
  EXPECT_EQ(fileBytes(cwd / "cpuw.ply"), one);
  EXPECT_EQ(fileBytes(cwd / "cpuw2.ply"), one);
  EXPECT_EQ(fileBytes(cwd / "cpu.ply"), one);
  // Streamed, a list of one device is that device; two devices, and the CPU beside one, stream
  // the same file.
  ASSERT_EQ(runCliSplit(base + "-o one_streamed.ply --backend vk --devices 0 --stream -q", cwd).status, 0);
  EXPECT_EQ(fileBytes(cwd / "one_streamed.ply"), one);
  r = runCliSplit(base + "-o two_streamed.ply --backend vk --devices 0,0 --stream -q", cwd);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(fileBytes(cwd / "two_streamed.ply"), one);
  r = runCliSplit(base + "-o cpuw_streamed.ply --backend vk --cpu-worker --stream -q", cwd);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(fileBytes(cwd / "cpuw_streamed.ply"), one);
  for (const auto& [list, problem] : std::vector<std::pair<std::string, std::string>>{
           {"0,nosuchgpu", "entry 'nosuchgpu' matches no Vulkan device (see `blobvk devices`)"},
           {"0,,0", "entry 2 is empty (a comma-separated list of device indices or names, or all)"},
           {"0,7", "entry '7': only 1 Vulkan device(s) (see `blobvk devices`)"}}) {
    const CliSplitRun bad = runCliSplit(base + "-o bad.ply --backend vk --devices " + list, cwd);
    EXPECT_EQ(bad.status, 1) << list;
    EXPECT_EQ(bad.err, "blobvk: error: --devices '" + list + "': " + problem + "\n") << list;
    EXPECT_FALSE(fs::exists(cwd / "bad.ply")) << list;
  }
  EXPECT_EQ(runCliSplit(base + "-o bad.ply --devices 0,0", cwd).status, 2);  // the cpu backend has no devices
  EXPECT_EQ(runCliSplit(base + "-o bad.ply --cpu-worker", cwd).status, 2);   // nor a CPU worker beside them
}

TEST_F(CliCommands, RenderWritesTheImageAskedFor) {
  const fs::path cwd = dir("render");
  CliSplitRun r = runCliSplit("render " + tower + " -o m.png --size 64x48 --resolution 32 --validation", cwd);
  ASSERT_EQ(r.status, 0) << r.err;
  const Rgba mesh = decodePng(fileBytes(cwd / "m.png"));
  ASSERT_EQ(mesh.width, 64u);
  ASSERT_EQ(mesh.height, 48u);
  // The corner is background; the model covers a good part of the frame.
  const unsigned char* corner = mesh.pixels.data();
  EXPECT_GT(mesh.pixelsDifferingFrom(corner[0], corner[1], corner[2]), 64u * 48u / 20u);
  r = runCliSplit("render " + tower + " -o c.png --size 64x48 --mode raycast", cwd);
  ASSERT_EQ(r.status, 0) << r.err;
  const Rgba cast = decodePng(fileBytes(cwd / "c.png"));
  ASSERT_EQ(cast.width, 64u);
  EXPECT_GT(cast.pixelsDifferingFrom(cast.pixels[0], cast.pixels[1], cast.pixels[2]), 64u * 48u / 20u);
  r = runCliSplit("render " + tower + " -o turn.png --size 32x32 --resolution 24 --turntable 3", cwd);
  ASSERT_EQ(r.status, 0) << r.err;
  for (const char* f : {"turn_000.png", "turn_001.png", "turn_002.png"}) EXPECT_EQ(decodePng(fileBytes(cwd / f)).width, 32u) << f;
  EXPECT_NE(fileBytes(cwd / "turn_000.png"), fileBytes(cwd / "turn_001.png"));
  // A frame between the first and last that cannot be written: the error names why, and the
  // frames written before it are removed.
  fs::create_directories(cwd / "blocked_001.png");
  r = runCliSplit("render " + tower + " -o blocked.png --size 32x32 --resolution 16 --turntable 3", cwd);
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.err.find("blocked_001.png: cannot write: Is a directory"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(cwd / "blocked_000.png"));
}

// A scene whose program is unbounded (a bend at the root) ray-casts within its grid bounds, as
// it is polygonized: the cast picture matches the mesh's (it once marched [-2, 2]^3 and cut the
// creature flat, PSNR 18.5 dB); its camera frames those bounds too.
TEST_F(CliCommands, AnUnboundedSceneRayCastsItsGridBounds) {
  const fs::path cwd = dir("unbounded");
  const CliSplitRun r = runCliSplit("compare " + sourcePath("scenes/creature.json") + " --resolution 64 --images --json", cwd);
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  const nlohmann::json report = nlohmann::json::parse(r.out);
  for (const auto& pair : report["images"]["pairs"]) EXPECT_TRUE(pair["pass"].get<bool>()) << pair.dump();
}

// The meshes are compared pixel for pixel, a mesh and the ray-cast within the mesh's own error
// (two grid cells on screen): the dice's CSG creases, which marching cubes cuts, fail no default.
TEST_F(CliCommands, CompareImagesPassesOnSharpCreasesWithTheDefaults) {
  const fs::path cwd = dir("creases");
  const CliSplitRun r = runCliSplit("compare " + sourcePath("scenes/dice.json") + " --images --json", cwd);
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  const nlohmann::json pairs = nlohmann::json::parse(r.out)["images"]["pairs"];
  ASSERT_EQ(pairs.size(), 2u);
  EXPECT_EQ(pairs[0]["search_radius_px"], 0);
  EXPECT_EQ(pairs[0]["fraction_over_tolerance"], 0.0);
  EXPECT_GE(pairs[1]["search_radius_px"].get<int>(), 2);
  EXPECT_LE(pairs[1]["search_radius_px"].get<int>(), 8);
}

// A camera nothing can be seen from is refused, not rendered blank: non-finite numbers are usage
// errors; an eye on its target (here an orbit of distance 0) an error naming it.
TEST_F(CliCommands, RenderRefusesCamerasThatSeeNothing) {
  const fs::path cwd = dir("camera");
  for (const std::string c : {"--camera nan,0", "--eye 1,inf,0", "--target 0,0,nan"}) {
    const CliSplitRun r = runCliSplit("render " + tower + " -o x.png --size 32x32 " + c, cwd);
    EXPECT_EQ(r.status, 2) << c << r.err;
  }
  // An orbit at distance 0 is a usage error, as the scene format's camera.distance > 0 is.
  CliSplitRun r = runCliSplit("render " + tower + " -o x.png --size 32x32 --camera 0,20,0", cwd);
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_NE(r.err.find("--camera: distance must be > 0"), std::string::npos) << r.err;
  r = runCliSplit("render " + tower + " -o x.png --size 32x32 --eye 1,2,3 --target 1,2,3", cwd);
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_NE(r.err.find("eye and target coincide"), std::string::npos) << r.err;
  r = runCliSplit("render " + tower + " -o x.png --size 32x32 --fov nan", cwd);
  EXPECT_NE(r.status, 0) << r.err;
  EXPECT_FALSE(fs::exists(cwd / "x.png"));
}

// An empty mesh is drawn (the background is an image) with a warning on both backends, even
// under -q; the summary names the triangles drawn, the vk backend's counted on the device.
TEST_F(CliCommands, RenderOfAnEmptyMeshWarns) {
  const fs::path cwd = dir("render_empty");
  for (const std::string backend : {"cpu", "vk"}) {
    CliSplitRun r = runCliSplit("render " + tower + " -o e.png --size 32x32 --resolution 2 -q --backend " + backend, cwd);
    EXPECT_EQ(r.status, 0) << r.err;
    EXPECT_NE(r.err.find("warning: the mesh is empty: no surface crosses the 4 x 4 x 4 grid"), std::string::npos) << r.err;
    r = runCliSplit("render " + tower + " -o f.png --size 32x32 --resolution 24 --backend " + backend, cwd);
    EXPECT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(r.err.find("warning"), std::string::npos) << r.err;
    const CliSplitRun m = runCliSplit("mesh " + tower + " -o f.ply --resolution 24 --json", cwd);
    ASSERT_EQ(m.status, 0) << m.err;
    const std::string triangles = std::to_string(nlohmann::json::parse(m.out)["triangles"].get<std::uint64_t>());
    EXPECT_NE(r.out.find(", " + triangles + " triangles"), std::string::npos) << backend << ": " << r.out;
  }
}

// --wireframe is honoured on every backend: the vk mesh is read back for its edges and the
// picture equals the cpu backend's (same mesh), and differs from the plain one.
TEST_F(CliCommands, RenderWireframeOnTheVulkanBackend) {
  const fs::path cwd = dir("wireframe");
  const std::string base = "render " + tower + " --size 96x96 --resolution 24 ";
  ASSERT_EQ(runCliSplit(base + "-o plain.png --backend vk", cwd).status, 0);
  CliSplitRun r = runCliSplit(base + "-o vk.png --backend vk --wireframe", cwd);
  ASSERT_EQ(r.status, 0) << r.err;
  ASSERT_EQ(runCliSplit(base + "-o cpu.png --backend cpu --wireframe", cwd).status, 0);
  const Rgba plain = decodePng(fileBytes(cwd / "plain.png")), vk = decodePng(fileBytes(cwd / "vk.png")),
             cpu = decodePng(fileBytes(cwd / "cpu.png"));
  ASSERT_EQ(vk.width, 96u);
  EXPECT_GT(vk.pixelsDifferingFrom(plain, 8), 96u * 96u / 100u);
  EXPECT_LE(vk.pixelsDifferingFrom(cpu, 8), 96u * 96u / 200u);
  EXPECT_EQ(runCliSplit(base + "-o x.png --mode raycast --wireframe", cwd).status, 2);
  // The ray-caster meshes nothing: mesh mode's options are refused with it, not ignored.
  for (const std::string option : {"--samples 2", "--backend vk", "--cell-size 0.5"}) {
    r = runCliSplit("render " + tower + " --size 32x32 -o x.png --mode raycast " + option, cwd);
    EXPECT_EQ(r.status, 2) << option;
    EXPECT_NE(r.err.find("is for --mode mesh"), std::string::npos) << r.err;
  }
  EXPECT_FALSE(fs::exists(cwd / "x.png"));
}

// What a CI reads of a failed compare: the report before the verdict in a merged log, a verdict
// naming every failure, the thresholds in force in the JSON, and a report lost to a full disk
// as an error (exit 1), not as a plain mismatch. The creature's Ricci blends and warps give
// fields a few ulps apart on lavapipe, so a zero field threshold fails.
TEST_F(CliCommands, AFailedCompareReportsFirstThenNamesItsFailures) {
  const std::string creature = sourcePath("scenes/creature.json");
  const CliRun merged = runCli("compare " + creature + " --resolution 24 --max-field-diff 0");
  ASSERT_EQ(merged.status, 3) << merged.output;
  const std::size_t report = merged.output.find("\nFAIL\n"), verdict = merged.output.find("blobvk: comparison failed:");
  ASSERT_NE(report, std::string::npos) << merged.output;
  ASSERT_NE(verdict, std::string::npos) << merged.output;
  EXPECT_LT(report, verdict) << merged.output;
  EXPECT_NE(merged.output.find("max field difference"), std::string::npos) << merged.output;

  const fs::path cwd = dir("compare_failed");
  const CliSplitRun r = runCliSplit("compare " + creature + " --resolution 24 --max-field-diff 0 --json", cwd);
  ASSERT_EQ(r.status, 3) << r.err;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["pass"], false);
  EXPECT_EQ(j["thresholds"]["max_field_diff"], 0.0);
  EXPECT_EQ(j["thresholds"]["max_hausdorff_cells"], 0.05);
  EXPECT_EQ(j["cpu_backend"], "cpu");
  EXPECT_EQ(j["features"], false);
  ASSERT_EQ(j["failures"].size(), 1u);

  const std::string errFile = (cwd / "err.txt").string();
  const int raw = std::system((std::string(BLOBVK_CLI) + " compare " + creature +
                               " --resolution 24 --max-field-diff 0 >/dev/full 2>'" + errFile + "'").c_str());
  EXPECT_EQ(WIFEXITED(raw) ? WEXITSTATUS(raw) : -1, 1);
  const std::string err = fileBytes(errFile);
  EXPECT_NE(err.find("comparison failed"), std::string::npos) << err;
  EXPECT_NE(err.find("standard output: write error"), std::string::npos) << err;
}

// Two empty meshes agree and check nothing: compare says so, as mesh and render do.
TEST_F(CliCommands, CompareOfEmptyMeshesWarns) {
  const CliSplitRun r = runCliSplit("compare " + tower + " --resolution 2 -q", dir("compare_empty"));
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.err.find("blobvk compare: warning: the mesh is empty: no surface crosses the 4 x 4 x 4 grid"),
            std::string::npos)
      << r.err;
}

TEST_F(CliCommands, CompareJsonNamesVersionDeviceAndDriver) {
  const fs::path cwd = dir("compare");
  CliSplitRun r = runCliSplit("compare " + tower + " --resolution 24 --json", cwd);
  ASSERT_EQ(r.status, 0) << r.err << r.out;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["blobvk_version"], BLOBVK_VERSION);
  EXPECT_EQ(j["device"]["driver_name"], "llvmpipe");
  EXPECT_EQ(j["pass"], true);
  EXPECT_EQ(j["mesh"]["identical_topology"], true);
  ASSERT_EQ(runCliSplit("mesh " + tower + " -o t.ply --resolution 24 -q", cwd).status, 0);
  EXPECT_EQ(j["mesh"]["cpu"]["triangles"].get<std::size_t>(), blobvk::mesh::readPly((cwd / "t.ply").string()).triangleCount());
  // The grid under the keys `mesh --json` gives it.
  const CliSplitRun meshed = runCliSplit("mesh " + tower + " -o t.ply --resolution 24 -q --json", cwd);
  ASSERT_EQ(meshed.status, 0) << meshed.err;
  const nlohmann::json m = nlohmann::json::parse(meshed.out);
  EXPECT_EQ(j["grid"]["cells"], m["grid"]["cells"]);
  EXPECT_EQ(j["grid"]["cell_size"], m["grid"]["cell_size"]);

  // A zero threshold: either the fields agree exactly, or the message shows the difference
  // with enough digits that it is visibly above zero.
  r = runCliSplit("compare " + tower + " --resolution 24 --max-field-diff 0", cwd);
  const double maxDiff = j["field"]["max_abs_diff"].get<double>();
  if (maxDiff == 0.0) {
    EXPECT_EQ(r.status, 0) << r.err;
  } else {
    EXPECT_EQ(r.status, 3) << r.err;
    EXPECT_EQ(r.err.find("0.000000 > 0.000000"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("max field difference"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(" > 0"), std::string::npos) << r.err;
  }
}
#endif

}  // namespace
