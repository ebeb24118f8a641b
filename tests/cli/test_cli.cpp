// Runs the blobvk binary as a user would and checks what it prints, returns and writes.
#include "cli_files.h"
#include "run_cli.h"

#include "blobvk/mesh/checks.h"
#include "blobvk/mesh/io.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <regex>
#include <string>
#include <thread>
#include <vector>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

namespace {

using blobvk::testing::CliRun;

CliRun run(const std::string& args) { return blobvk::testing::runCli(args); }

std::string source(const std::string& rel) { return std::string(BLOBVK_SOURCE_DIR) + "/" + rel; }

std::filesystem::path scratch(const std::string& name) { return blobvk::testing::scratchDir() / name; }

std::size_t lines(const std::string& s) {
  std::size_t n = 0;
  for (char c : s) n += c == '\n';
  return n;
}

}  // namespace

TEST(Cli, MeshOfTheTowerIsClosedAndManifold) {
  const auto out = scratch("tower.ply");
  const CliRun r = run("mesh " + source("scenes/tower.json") + " -o " + out.string() + " --resolution 64");
  ASSERT_EQ(r.status, 0) << r.output;
  const blobvk::mesh::MeshReport report = blobvk::mesh::checkMesh(blobvk::mesh::readPly(out.string()));
  EXPECT_GT(report.triangles, 1000u);
  EXPECT_TRUE(report.watertight()) << report.summary();
  EXPECT_GT(report.volume, 0.0);
}

// Out of core: --stream, or a --max-memory budget the whole mesh may not fit, writes the file
// layer by layer; every format's bytes equal the in-memory run's, and the streamed check's line
// equals the in-memory check's.
TEST(Cli, StreamedMeshFilesEqualInMemoryOnes) {
  const std::string scene = source("scenes/twisted_column.json");
  for (const std::string& ext : {std::string("ply"), std::string("obj"), std::string("stl")}) {
    for (const std::string& extra : {std::string(), std::string(ext == "ply" ? " --ascii" : "")}) {
      if (ext != "ply" && !extra.empty()) continue;
      const auto a = scratch("mem." + ext), b = scratch("str." + ext);
      const CliRun mem = run("mesh " + scene + " -o " + a.string() + " --resolution 40 --mpu 6" + extra);
      const CliRun str = run("mesh " + scene + " -o " + b.string() + " --resolution 40 --mpu 6 --stream" + extra);
      ASSERT_EQ(mem.status, 0) << mem.output;
      ASSERT_EQ(str.status, 0) << str.output;
      EXPECT_NE(str.output.find("(streamed)"), std::string::npos) << str.output;
      EXPECT_EQ(blobvk::testing::fileBytes(a), blobvk::testing::fileBytes(b)) << ext << extra;
      // The check line (the last line) is the same.
      EXPECT_EQ(mem.output.substr(mem.output.rfind('\n', mem.output.size() - 2)),
                str.output.substr(str.output.rfind('\n', str.output.size() - 2)));
    }
  }
  // A budget below the in-memory estimate streams by itself; standard output streams too.
  const auto a = scratch("budget_mem.ply"), b = scratch("budget_str.ply");
  ASSERT_EQ(run("mesh " + scene + " -o " + a.string() + " --resolution 200 -q").status, 0);
  const CliRun budget = run("mesh " + scene + " -o " + b.string() + " --resolution 200 --max-memory 40M");
  ASSERT_EQ(budget.status, 0) << budget.output;
  EXPECT_NE(budget.output.find("(streamed)"), std::string::npos) << budget.output;
  EXPECT_NE(budget.output.find("; watertight"), std::string::npos) << budget.output;
  EXPECT_EQ(blobvk::testing::fileBytes(a), blobvk::testing::fileBytes(b));
  const auto c = scratch("stdout.ply");
  ASSERT_EQ(std::system((std::string(BLOBVK_CLI) + " mesh " + scene + " -o - --resolution 200 --stream -q > " + c.string()).c_str()), 0);
  EXPECT_EQ(blobvk::testing::fileBytes(a), blobvk::testing::fileBytes(c));
  // Nothing else is left beside the outputs (spools unlinked, temporaries renamed).
  for (const auto& e : std::filesystem::directory_iterator(a.parent_path()))
    EXPECT_EQ(e.path().filename().string().find(".blobvk-"), std::string::npos) << e.path();
  // Formats that need the whole mesh, and other backends, are refused with a clear line.
  const CliRun vk = run("mesh " + scene + " -o " + scratch("vk.ply").string() + " --resolution 40 --backend reference --stream");
  EXPECT_NE(vk.status, 0);
  EXPECT_NE(vk.output.find("cpu and vk backends"), std::string::npos) << vk.output;
}

#ifdef BLOBVK_HAVE_VULKAN
// The vk backend streams batch by batch of brick layers: the same bytes as the cpu backend's
// in-memory file, and the same check line; a --max-memory budget below the in-memory estimate
// streams by itself.
TEST(Cli, StreamedVulkanMeshFilesEqualTheCpuFiles) {
  const std::string scene = source("scenes/tower.json");
  const auto cpu = scratch("vk_cpu.ply"), str = scratch("vk_str.ply"), budget = scratch("vk_budget.ply");
  const CliRun mem = run("mesh " + scene + " -o " + cpu.string() + " --resolution 96");
  const CliRun vk = run("mesh " + scene + " -o " + str.string() + " --resolution 96 --backend vk --stream");
  ASSERT_EQ(mem.status, 0) << mem.output;
  ASSERT_EQ(vk.status, 0) << vk.output;
  EXPECT_NE(vk.output.find("backend vk (streamed)"), std::string::npos) << vk.output;
  EXPECT_EQ(blobvk::testing::fileBytes(cpu), blobvk::testing::fileBytes(str));
  EXPECT_EQ(mem.output.substr(mem.output.rfind('\n', mem.output.size() - 2)),
            vk.output.substr(vk.output.rfind('\n', vk.output.size() - 2)));
  const auto cpu200 = scratch("vk_cpu200.ply");
  ASSERT_EQ(run("mesh " + scene + " -o " + cpu200.string() + " --resolution 200 -q").status, 0);
  const CliRun small = run("mesh " + scene + " -o " + budget.string() + " --resolution 200 --backend vk --max-memory 40M");
  ASSERT_EQ(small.status, 0) << small.output;
  EXPECT_NE(small.output.find("backend vk (streamed)"), std::string::npos) << small.output;
  EXPECT_EQ(blobvk::testing::fileBytes(cpu200), blobvk::testing::fileBytes(budget));
  // --json says what ran on the device, as the in-memory run does.
  const CliRun json = run("mesh " + scene + " -o " + scratch("vk_json.ply").string() + " --resolution 96 --backend vk --stream --json");
  ASSERT_EQ(json.status, 0) << json.output;
  const nlohmann::json j = nlohmann::json::parse(json.output.substr(json.output.find('{')));
  EXPECT_EQ(j["streamed"], true);
  EXPECT_GE(j["gpu"]["batches"].get<int>(), 1) << json.output;
  EXPECT_GT(j["gpu"]["active_bricks"].get<int>(), 0) << json.output;
  EXPECT_FALSE(j["gpu"]["evaluator"].get<std::string>().empty()) << json.output;
  EXPECT_EQ(j["device"]["driver_name"], "llvmpipe") << json.output;
  // Several devices, and the CPU beside a device, stream the same file.
  const auto cpu32 = scratch("vk_cpu32.ply");
  ASSERT_EQ(run("mesh " + scene + " -o " + cpu32.string() + " --resolution 32 -q").status, 0);
  for (const std::string workers : {"--devices 0,0", "--cpu-worker"}) {
    const auto out = scratch("vk_workers.ply");
    const CliRun r = run("mesh " + scene + " -o " + out.string() + " --resolution 32 --backend vk --stream " + workers);
    ASSERT_EQ(r.status, 0) << workers << r.output;
    EXPECT_NE(r.output.find("backend vk (streamed)"), std::string::npos) << workers << r.output;
    EXPECT_EQ(blobvk::testing::fileBytes(cpu32), blobvk::testing::fileBytes(out)) << workers;
  }
}
#endif

TEST(Cli, BackendsAndThreadCountsWriteIdenticalFiles) {
  const auto a = scratch("a.ply"), b = scratch("b.ply"), c = scratch("c.ply");
  const std::string scene = source("scenes/twisted_column.json");
  ASSERT_EQ(run("mesh " + scene + " -o " + a.string() + " --resolution 48 --threads 1 -q").status, 0);
  ASSERT_EQ(run("mesh " + scene + " -o " + b.string() + " --resolution 48 --threads 2 -q").status, 0);
  ASSERT_EQ(run("mesh " + scene + " -o " + c.string() + " --resolution 48 --backend reference -q").status, 0);
  auto bytes = [](const std::filesystem::path& p) {
    std::ifstream in(p, std::ios::binary);
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  };
  EXPECT_EQ(bytes(a), bytes(b));
  EXPECT_EQ(bytes(a), bytes(c));
}

// --features after any backend: the same bytes from the CPU, the reference and Vulkan (lavapipe
// gives the CPU's mesh bit for bit, and the pass runs on the host), and the check line says what
// the pass did, with the mesh still watertight.
TEST(Cli, SharpFeaturesGiveTheSameFileOnEveryBackend) {
  const std::string scene = source("scenes/dice.json");
  auto bytes = [](const std::filesystem::path& p) {
    std::ifstream in(p, std::ios::binary);
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  };
  std::vector<std::string> backends = {"cpu", "reference"};
#ifdef BLOBVK_HAVE_VULKAN
  backends.push_back("vk");  // the sanitizer build has no Vulkan backend
#endif
  std::string first;
  for (const std::string& backend : backends) {
    const auto out = scratch("features_" + backend + ".ply");
    const CliRun r = run("mesh " + scene + " -o " + out.string() + " --resolution 40 --features --backend " + backend);
    ASSERT_EQ(r.status, 0) << r.output;
    EXPECT_NE(r.output.find("watertight"), std::string::npos) << r.output;
    EXPECT_TRUE(std::regex_search(r.output, std::regex(R"(features: [1-9]\d* vertices, \d+ flips)"))) << r.output;
    if (first.empty()) first = bytes(out);
    else EXPECT_EQ(bytes(out), first) << backend;
  }
  const CliRun streamed = run("mesh " + scene + " -o " + scratch("s.ply").string() + " --resolution 40 --features --stream");
  EXPECT_NE(streamed.status, 0);
  EXPECT_NE(streamed.output.find("--features"), std::string::npos) << streamed.output;
}

TEST(Cli, BadInputGivesOneLineAndNonZeroExit) {
  const auto bad = scratch("bad.json");
  std::ofstream(bad) << R"({"blobvk": 1, "root": {"type": "point", "support": -1}})";
  const CliRun r = run("mesh " + bad.string() + " -o " + scratch("x.ply").string());
  EXPECT_NE(r.status, 0);
  EXPECT_EQ(lines(r.output), 1u) << r.output;
  EXPECT_NE(r.output.find(bad.string()), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("/root/support"), std::string::npos) << r.output;

  const CliRun missing = run("info " + scratch("does_not_exist.json").string());
  EXPECT_NE(missing.status, 0);
  EXPECT_EQ(lines(missing.output), 1u) << missing.output;

  const CliRun backend = run("mesh " + source("scenes/tower.json") + " -o " + scratch("y.ply").string() + " --backend nope");
  EXPECT_EQ(backend.status, 2);  // a usage error, naming the backends there are
  EXPECT_NE(backend.output.find("reference"), std::string::npos) << backend.output;
}

TEST(Cli, ResourceLimitsRefuseEarly) {
  const CliRun mem = run("mesh " + source("scenes/tower.json") + " -o " + scratch("m.ply").string() +
                      " --resolution 1500 --max-memory 64M");
  EXPECT_NE(mem.status, 0);
  EXPECT_NE(mem.output.find("--max-memory"), std::string::npos) << mem.output;
  EXPECT_FALSE(std::filesystem::exists(scratch("m.ply")));

  const CliRun tris = run("mesh " + source("scenes/tower.json") + " -o " + scratch("t.ply").string() +
                       " --resolution 32 --max-triangles 10");
  EXPECT_NE(tris.status, 0);
  EXPECT_NE(tris.output.find("--max-triangles"), std::string::npos) << tris.output;
  EXPECT_FALSE(std::filesystem::exists(scratch("t.ply")));
  // Streamed, the job stops at the first layer that passes the limit (of 4 layers of MPUs here).
  const CliRun streamed = run("mesh " + source("scenes/tower.json") + " -o " + scratch("t.ply").string() +
                              " --resolution 64 --stream --max-triangles 10");
  EXPECT_EQ(streamed.status, 1);
  EXPECT_NE(streamed.output.find("more than --max-triangles 10 triangles ("), std::string::npos) << streamed.output;
  EXPECT_EQ(streamed.output.find("mesh 100%"), std::string::npos) << streamed.output;
  EXPECT_FALSE(std::filesystem::exists(scratch("t.ply")));
}

TEST(Cli, GenerateConvertInfoRoundTrip) {
  const auto tower = scratch("gen_tower.json");
  CliRun r = run("generate tower --levels 2 --pillars 4 --grid 2 -o " + tower.string());
  ASSERT_EQ(r.status, 0) << r.output;
  r = run("info " + tower.string());
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("field registers"), std::string::npos);

  const auto converted = scratch("peanut.json");
  r = run("convert " + source("scenes/legacy/peanut.blob") + " " + converted.string());
  ASSERT_EQ(r.status, 0) << r.output;
  r = run("mesh " + converted.string() + " -o " + scratch("peanut.ply").string() + " --resolution 32");
  EXPECT_EQ(r.status, 0) << r.output;
}

// A soft body under too long a time step blows up: simulate and cut stop with one line naming the
// scene and the step, instead of writing frames whose positions are past float range (infinities)
// and exiting 0.
TEST(Cli, ADivergingSimulationStopsWithAnError) {
  std::ifstream in(source("scenes/soft_peanut.json"));
  nlohmann::json scene = nlohmann::json::parse(in);
  scene["simulation"]["materials"][0]["E"] = 1;
  scene["simulation"]["timeStep"] = 1;
  const auto path = scratch("diverging.json");
  std::ofstream(path) << scene.dump();
  for (const char* command : {"simulate", "cut"}) {
    const CliRun r = run(std::string(command) + " " + path.string() + " -o " + scratch(std::string("div_") + command).string() +
                         " --steps 20 --no-png -q");
    EXPECT_EQ(r.status, 1) << command << r.output;
    EXPECT_NE(r.output.find("diverging.json: /simulation: the simulation diverged at step"), std::string::npos)
        << command << r.output;
  }
}

// The first child of `parent` in /proc, or 0; and whether a process still runs (a zombie has ended).
pid_t childOf(pid_t parent) {
  for (const auto& entry : std::filesystem::directory_iterator("/proc")) {
    std::ifstream stat(entry.path() / "stat");
    std::string line;
    if (!std::getline(stat, line)) continue;
    const std::size_t close = line.rfind(')');  // the command name may hold spaces
    char state = 0;
    int ppid = 0;
    if (close != std::string::npos && std::sscanf(line.c_str() + close + 1, " %c %d", &state, &ppid) == 2 && ppid == parent)
      return pid_t(std::stoi(entry.path().filename().string()));
  }
  return 0;
}
bool running(pid_t pid) {
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string line;
  if (!std::getline(stat, line)) return false;
  const std::size_t close = line.rfind(')');
  return close != std::string::npos && close + 2 < line.size() && line[close + 2] != 'Z';
}

// TetGen runs in a child process (fem::TetgenOptions::isolateInChildProcess): a job runner that
// kills blobvk while TetGen meshes must not leave TetGen computing on as an orphan.
TEST(Cli, KillingTheCommandEndsItsTetgenProcess) {
  nlohmann::json scene = nlohmann::json::parse(std::ifstream(source("scenes/soft_peanut.json")));
  // TetGen cannot meet these bounds: it adds points up to its limit, for seconds.
  scene["simulation"]["tetgen"]["radiusEdge"] = 1.0;
  scene["simulation"]["tetgen"]["minDihedral"] = 25;
  const auto path = scratch("slow_tetgen.json");
  std::ofstream(path) << scene.dump();
  const std::string out = scratch("slow_tetgen_frames").string();
  const pid_t command = fork();
  ASSERT_GE(command, 0);
  if (command == 0) {
    std::freopen("/dev/null", "w", stderr);
    execl(BLOBVK_CLI, BLOBVK_CLI, "simulate", path.c_str(), "-o", out.c_str(), "--steps", "1", "--no-png", "-q",
          static_cast<char*>(nullptr));
    _exit(127);
  }
  pid_t tetgen = 0;
  for (int i = 0; i < 3000 && tetgen == 0 && running(command); ++i) {
    tetgen = childOf(command);
    if (tetgen == 0) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  kill(command, SIGKILL);
  waitpid(command, nullptr, 0);
  ASSERT_NE(tetgen, 0) << "blobvk simulate started no TetGen process within 30 s";
  bool ended = false;
  for (int i = 0; i < 500 && !ended; ++i) {
    ended = !running(tetgen);
    if (!ended) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  if (!ended) kill(tetgen, SIGKILL);  // leave no orphan behind whatever the verdict
  EXPECT_TRUE(ended) << "TetGen (pid " << tetgen << ") outlived the killed command by 5 s";
}

TEST(Cli, SimulateAndCutTheSoftPeanut) {
  const auto frames = scratch("sim");
  CliRun r = run("simulate " + source("scenes/soft_peanut.json") + " -o " + frames.string() + " --steps 20");
  ASSERT_EQ(r.status, 0) << r.output;
  ASSERT_TRUE(std::filesystem::exists(frames / "frame_00002.ply")) << r.output;
  // The fixed region holds the body: after 0.2 s a free fall would have dropped it by 0.2.
  auto lowest = [&](const char* name) {
    float y = 1e30f;
    for (const auto& p : blobvk::mesh::readPly((frames / name).string()).positions) y = std::min(y, p.y);
    return y;
  };
  EXPECT_GT(lowest("frame_00002.ply"), lowest("frame_00000.ply") - 0.02f);
  // A frame is the body's closed surface, without the tet mesh's interior nodes.
  const blobvk::mesh::MeshReport frame = blobvk::mesh::checkMesh(blobvk::mesh::readPly((frames / "frame_00002.ply").string()));
  EXPECT_TRUE(frame.watertight()) << frame.summary();
  EXPECT_EQ(frame.unreferencedVertices, 0u) << frame.summary();
  // The solver's summary: every step met the tolerance.
  EXPECT_NE(r.output.find(", 0 steps at the cap"), std::string::npos) << r.output;
  const auto cut = scratch("cut");
  // The blade's keyframes are simulation times (0.05 .. 0.2 s): it cuts while the body moves.
  r = run("cut " + source("scenes/soft_peanut.json") + " -o " + cut.string() + " --steps 25 --no-png --vtu");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("self-check ok"), std::string::npos) << r.output;
  // The blade cuts the moving body in two: two parts of at least 30 % of the tets each, and no
  // fragment (kept or removed). ", 2 parts" alone passed on 23924 + 11 tets.
  std::smatch m;
  ASSERT_TRUE(std::regex_search(r.output, m, std::regex(R"(parts \(tets\): (\d+), (\d+)\n)"))) << r.output;
  const double a = std::stod(m[1]), b = std::stod(m[2]);
  EXPECT_GE(b, 0.3 * (a + b)) << r.output;
  EXPECT_NE(r.output.find("fragments: 0 removed (0 tets), 0 kept (0 tets)"), std::string::npos) << r.output;
  EXPECT_TRUE(std::filesystem::exists(cut / "frame_00001.ply")) << r.output;
  EXPECT_TRUE(std::filesystem::exists(cut / "stats.csv")) << r.output;
  // --vtu: the tet mesh beside each PLY frame (its format is checked in surgery_tests).
  std::ifstream vtu(cut / "frame_00001.vtu");
  std::string head((std::istreambuf_iterator<char>(vtu)), std::istreambuf_iterator<char>());
  EXPECT_NE(head.find("<VTKFile type=\"UnstructuredGrid\""), std::string::npos);
  EXPECT_NE(head.find("Name=\"part\""), std::string::npos);
  std::ifstream statsFile(cut / "stats.csv");
  std::string header;
  std::getline(statsFile, header);
  EXPECT_NE(header.find(",cg_iterations,cg_residual"), std::string::npos) << header;
}

// --fragment-tets N makes every part (but the largest) of at most N tets a fragment: the peanut's
// smaller half is removed (and reported with its size) or kept (and reported).
TEST(Cli, CutRemovesOrKeepsFragmentsBySize) {
  for (const std::string policy : {"remove", "keep"}) {
    const auto out = scratch("frag_" + policy);
    const CliRun r = run("cut " + source("scenes/soft_peanut.json") + " -o " + out.string() +
                         " --steps 25 --no-png --fragment-tets 15000 --fragments " + policy);
    ASSERT_EQ(r.status, 0) << r.output;
    std::smatch m;
    if (policy == "remove") {
      ASSERT_TRUE(std::regex_search(r.output, m, std::regex(R"(parts \(tets\): (\d+)\nfragments: 1 removed \((\d+) tets\), 0 kept)"))) << r.output;
      EXPECT_GE(std::stod(m[2]), 0.3 * (std::stod(m[1]) + std::stod(m[2]))) << r.output;
      EXPECT_LE(std::stoi(m[2]), 15000) << r.output;
    } else {
      ASSERT_TRUE(std::regex_search(r.output, m, std::regex(R"(parts \(tets\): (\d+), (\d+)\nfragments: 0 removed \(0 tets\), 1 kept \((\d+) tets\))"))) << r.output;
      EXPECT_EQ(m[2], m[3]) << r.output;
    }
  }
}

// A malformed simulation.lift is refused before any work, naming the file and the JSON pointer.
TEST(Cli, CutRejectsAMalformedLiftNamingTheKey) {
  std::ifstream in(source("scenes/soft_peanut.json"));
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string anchor = "\"steps\": 100";
  ASSERT_NE(text.find(anchor), std::string::npos);
  auto withLift = [&](const std::string& lift) {
    std::string scene = text;
    scene.replace(scene.find(anchor), anchor.size(), "\"lift\": " + lift + ", " + anchor);
    const auto file = scratch("lift.json");
    std::ofstream(file) << scene;
    return run("cut " + file.string() + " -o " + scratch("lift_out").string() + " --steps 1 --no-png");
  };
  CliRun r = withLift(R"({"near": [0, 1], "path": [{"t": 0}]})");
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.output.find("lift.json"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("/simulation/lift/near"), std::string::npos) << r.output;
  r = withLift(R"({"near": [0, 1, 0], "path": [{"t": 0}, {"t": 0.1, "rotate": {"axis": [0, 0, 0], "degrees": 30}}]})");
  EXPECT_NE(r.output.find("/simulation/lift/path/1/rotate/axis"), std::string::npos) << r.output;
  r = withLift(R"({"near": [0, 1, 0], "path": [{"t": 0.2}, {"t": 0.1}]})");
  EXPECT_NE(r.output.find("/simulation/lift/path/1/t"), std::string::npos) << r.output;
  r = withLift(R"({"near": [0, 1, 0], "grip": 1, "path": [{"t": 0}]})");
  EXPECT_NE(r.output.find("/simulation/lift/grip"), std::string::npos) << r.output;
}

// blobvk with the loader pointed at a driver manifest that does not exist: no device at all.
CliRun runWithoutVulkanDriver(const std::string& args) {
  const std::string env = "VK_ICD_FILENAMES=/nonexistent/icd.json VK_DRIVER_FILES=/nonexistent/icd.json ";
  FILE* pipe = popen((env + BLOBVK_CLI + " " + args + " 2>&1").c_str(), "r");
  if (!pipe) return {-1, "popen failed"};
  CliRun r;
  std::array<char, 4096> buf{};
  while (std::fgets(buf.data(), int(buf.size()), pipe)) r.output += buf.data();
  const int raw = pclose(pipe);
  r.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
  return r;
}

TEST(Cli, NoVulkanDriverGivesAClearError) {
  const CliRun r = runWithoutVulkanDriver("mesh " + source("scenes/tower.json") + " -o " + scratch("novk.ply").string() +
                                          " --backend vk --resolution 16");
  EXPECT_EQ(r.status, 1) << r.output;
  // A build without the Vulkan backend (the sanitizer build) says so instead.
  const char* reason = BLOBVK_CLI_WITH_VULKAN ? "mesa-vulkan-drivers" : "built without Vulkan";
  EXPECT_NE(r.output.find(reason), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(scratch("novk.ply")));
}

// PNG frames of simulate and cut are left out with a warning where there is no device, unless
// the user asked for a PNG size: then the run stops before any work and makes no folder.
TEST(Cli, SimulateWithoutADeviceDropsPngFramesUnlessASizeWasAskedFor) {
  const std::string scene = source("scenes/soft_peanut.json");
  const auto asked = scratch("novk_sized"), plain = scratch("novk_plain");
  std::filesystem::remove_all(asked);
  CliRun r = runWithoutVulkanDriver("simulate " + scene + " -o " + asked.string() + " --steps 1 --resolution 12 --image-size 64");
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("--image-size 64: cannot render PNG frames"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(asked));
  r = runWithoutVulkanDriver("simulate " + scene + " -o " + plain.string() + " --steps 1 --resolution 12");
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("warning: no PNG frames"), std::string::npos) << r.output;
  EXPECT_TRUE(std::filesystem::exists(plain / "frame_00001.ply")) << r.output;
}

// Inputs first: a scene or blade file that fails to load leaves no output folder; a PNG size
// with --no-png is a usage error; a body of a handful of tets is run, with a warning saying so.
TEST(Cli, SimulateAndCutMakeNothingUntilTheirInputsLoad) {
  const auto out = scratch("never_made");
  std::filesystem::remove_all(out);
  for (const char* command : {"simulate", "cut"}) {
    CliRun r = run(std::string(command) + " " + scratch("no_such_scene.json").string() + " -o " + out.string() + " --no-png");
    EXPECT_EQ(r.status, 1) << r.output;
    EXPECT_NE(r.output.find("no_such_scene.json: cannot open"), std::string::npos) << r.output;
    EXPECT_FALSE(std::filesystem::exists(out)) << command;
    r = run(std::string(command) + " " + source("scenes/soft_peanut.json") + " -o " + out.string() + " --no-png --image-size 64");
    EXPECT_EQ(r.status, 2) << r.output;
    EXPECT_FALSE(std::filesystem::exists(out)) << command;
    // A scene that loads but has no simulation section, or a bad one, is refused before the folder.
    r = run(std::string(command) + " " + source("scenes/tower.json") + " -o " + out.string() + " --no-png");
    EXPECT_EQ(r.status, 1) << r.output;
    EXPECT_NE(r.output.find("tower.json: the scene has no \"simulation\" section"), std::string::npos) << r.output;
    EXPECT_FALSE(std::filesystem::exists(out)) << command;
  }
  std::ifstream in(source("scenes/soft_peanut.json"));
  nlohmann::json scene = nlohmann::json::parse(in);
  scene["simulation"]["timeStep"] = -1;
  const auto badSection = scratch("bad_section.json");
  std::ofstream(badSection) << scene.dump();
  for (const char* command : {"simulate", "cut"}) {
    const CliRun r = run(std::string(command) + " " + badSection.string() + " -o " + out.string() + " --no-png");
    EXPECT_EQ(r.status, 1) << r.output;
    EXPECT_NE(r.output.find("bad_section.json: /simulation/timeStep"), std::string::npos) << r.output;
    EXPECT_FALSE(std::filesystem::exists(out)) << command;
  }
  // cut without a blade path (none in the scene, no --blade): refused before the folder too.
  in.clear();
  in.seekg(0);
  nlohmann::json bladeless = nlohmann::json::parse(in);
  ASSERT_TRUE(bladeless["simulation"].contains("blade"));
  bladeless["simulation"].erase("blade");
  const auto noBlade = scratch("no_blade.json");
  std::ofstream(noBlade) << bladeless.dump();
  const CliRun cut = run("cut " + noBlade.string() + " -o " + out.string() + " --no-png");
  EXPECT_EQ(cut.status, 1) << cut.output;
  EXPECT_NE(cut.output.find("no_blade.json: /simulation/blade: no blade path"), std::string::npos) << cut.output;
  EXPECT_FALSE(std::filesystem::exists(out));
  const CliRun blade = run("cut " + source("scenes/soft_peanut.json") + " -o " + out.string() + " --no-png --blade " +
                           scratch("no_such_blade.json").string());
  EXPECT_EQ(blade.status, 1) << blade.output;
  EXPECT_FALSE(std::filesystem::exists(out));
  // A folder given as the blade file: named, in one line.
  const CliRun folder = run("cut " + source("scenes/soft_peanut.json") + " -o " + out.string() + " --no-png --blade " +
                            scratch("").string());
  EXPECT_EQ(folder.status, 1) << folder.output;
  EXPECT_NE(folder.output.find(": is a directory, not a blade path file"), std::string::npos) << folder.output;
  EXPECT_FALSE(std::filesystem::exists(out));
  const CliRun coarse = run("simulate " + source("scenes/soft_peanut.json") + " -o " + out.string() + " --no-png --steps 1 --resolution 4");
  EXPECT_EQ(coarse.status, 0) << coarse.output;
  EXPECT_NE(coarse.output.find("warning: " + source("scenes/soft_peanut.json") + ": the soft body has only"), std::string::npos)
      << coarse.output;
  const CliRun fine = run("simulate " + source("scenes/soft_peanut.json") + " -o " + out.string() + " --no-png --steps 1 --resolution 16");
  EXPECT_EQ(fine.status, 0) << fine.output;
  EXPECT_EQ(fine.output.find("the soft body has only"), std::string::npos) << fine.output;
}
