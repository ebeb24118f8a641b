// The thesis' evaluation scenes (scenes/eggshell_sim.json, scenes/craniotomy.json) run end to end
// through the blobvk binary, as a user would: `blobvk cut` simulates while the blade cuts, the
// topology passes its self-check after every event, a freed part is lifted along the scene's
// path, the tools' forces are reported (stats.csv) and the simulation stays finite (the CLI
// fails on NaN).
#include "tests/cli/run_cli.h"
#include "blobvk/blobtree/evaluate.h"
#include "blobvk/blobtree/scene_json.h"
#include "blobvk/mesh/io.h"

#include <glm/common.hpp>
#include <glm/vec3.hpp>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numeric>
#include <regex>
#include <sstream>
#include <string>
#include <sys/wait.h>
#include <unistd.h>

namespace {

using namespace blobvk;

using blobvk::testing::CliRun;

CliRun run(const std::string& args) { return blobvk::testing::runCli(args); }

std::string source(const std::string& rel) { return std::string(BLOBVK_SOURCE_DIR) + "/" + rel; }

std::filesystem::path scratch(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() / ("blobvk_eval_" + std::to_string(getpid())) / name;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

// "cut: 43 events in 625.5 ms, 3 parts; self-check ok (and after each of 42 changing events); ..."
struct CutLine {
  int events = -1, parts = -1, checkedEvents = -1;
  bool selfCheckOk = false;
};
CutLine parseCut(const std::string& output) {
  CutLine c;
  std::smatch m;
  if (std::regex_search(output, m, std::regex(R"(cut: (\d+) events in [0-9.]+ ms, (\d+) parts; self-check (\w+))"))) {
    c.events = std::stoi(m[1]);
    c.parts = std::stoi(m[2]);
    c.selfCheckOk = m[3] == "ok";
  }
  if (std::regex_search(output, m, std::regex(R"(after each of (\d+) changing events)"))) c.checkedEvents = std::stoi(m[1]);
  return c;
}

// stats.csv: one row per frame, columns by header name.
struct Stats {
  std::vector<std::map<std::string, double>> rows;
};
Stats readStats(const std::filesystem::path& file) {
  std::ifstream in(file);
  Stats s;
  std::string line;
  std::vector<std::string> header;
  auto split = [](const std::string& l) {
    std::vector<std::string> cells;
    std::stringstream ss(l);
    for (std::string c; std::getline(ss, c, ',');) cells.push_back(c);
    return cells;
  };
  if (std::getline(in, line)) header = split(line);
  while (std::getline(in, line)) {
    const auto cells = split(line);
    std::map<std::string, double> row;
    for (std::size_t i = 0; i < cells.size() && i < header.size(); ++i) row[header[i]] = std::stod(cells[i]);
    s.rows.push_back(std::move(row));
  }
  return s;
}

// How far the scene's lift path finally carries the part: |translation of its last keyframe|.
double liftPathDistance(const std::string& scene) {
  std::ifstream in(source(scene));
  const nlohmann::json j = nlohmann::json::parse(in);
  const auto& t = j["simulation"]["lift"]["path"].back()["translate"];
  return std::sqrt(double(t[0]) * double(t[0]) + double(t[1]) * double(t[1]) + double(t[2]) * double(t[2]));
}

bool allFinite(const std::filesystem::path& ply) {
  for (const auto& p : mesh::readPly(ply.string()).positions)
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) return false;
  return true;
}

std::filesystem::path lastFrame(const std::filesystem::path& dir) {
  std::filesystem::path last;
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    if (e.path().extension() == ".ply" && (last.empty() || e.path().filename() > last.filename())) last = e.path();
  }
  return last;
}

// The common checks of one `blobvk cut` run: finished, self-check after every changing event,
// a part came free and was lifted along the scene's path, finite frames.
struct Procedure {
  CliRun run;
  CutLine cut;
  Stats stats;
  int liftedTets = 0;
};
Procedure runProcedure(const std::string& scene, const std::string& name, const std::string& extra) {
  const auto out = scratch(name);
  Procedure p;
  p.run = run("cut " + source(scene) + " -o " + out.string() + " --check-each-event --frame-every 10 --no-png " + extra);
  p.cut = parseCut(p.run.output);
  if (std::filesystem::exists(out / "stats.csv")) p.stats = readStats(out / "stats.csv");
  std::smatch m;
  if (std::regex_search(p.run.output, m, std::regex(R"(lift: a part of (\d+) tets)"))) p.liftedTets = std::stoi(m[1]);
  EXPECT_EQ(p.run.status, 0) << p.run.output;
  EXPECT_TRUE(p.cut.selfCheckOk) << p.run.output;
  EXPECT_GT(p.cut.checkedEvents, 5) << "the self-check did not run after every event:\n" << p.run.output;
  EXPECT_GT(p.liftedTets, 0) << "no part was lifted:\n" << p.run.output;
  EXPECT_GE(p.stats.rows.size(), 3u);
  if (!p.stats.rows.empty()) {
    const auto& last = p.stats.rows.back();
    EXPECT_EQ(last.at("lifted"), 1.0);
    // The lift is rigid and pinned: the part ends where the path puts it (within 10 %).
    const double path = liftPathDistance(scene);
    EXPECT_GT(last.at("lift_distance"), 0.9 * path) << "the freed part did not move away";
    EXPECT_LT(last.at("lift_distance"), 1.1 * path + 0.05);
  }
  EXPECT_TRUE(allFinite(lastFrame(out)));
  return p;
}

// The egg is held at its top and pressed by a probe; then a radial blade cuts a closed ring
// around its bottom while it moves, the cap comes free and is lifted away. The scene's own mesh
// (TetGen, ~13k tets: a coarser surface only gives worse tets and a slower solve).
TEST(Eggshell, ProbePressesThenTheCapIsCutOffAndLifted) {
  const Procedure p = runProcedure("scenes/eggshell_sim.json", "egg_cut", "");
  EXPECT_GE(p.cut.parts, 2) << p.run.output;  // the cap and the rest of the shell
  double probeBeforeCut = 0;
  for (const auto& row : p.stats.rows)
    if (row.at("cut_events") == 0) probeBeforeCut = std::max(probeBeforeCut, row.at("tool0_force"));
  EXPECT_GT(probeBeforeCut, 0.0) << "the probe never touched the shell before the cut";
  // The cut happened during the run: events grow over the frames, and the lift comes after them.
  ASSERT_GE(p.stats.rows.size(), 3u);
  EXPECT_EQ(p.stats.rows.front().at("cut_events"), 0.0);
  EXPECT_GT(p.stats.rows.back().at("cut_events"), 10.0);
}

// The saw cuts a closed oval through scalp and skull while the head is simulated; the bone flap
// comes free, is lifted up and aside, and the retractor enters the opening and presses the brain.
TEST(Craniotomy, BoneFlapIsCutFreeLiftedAndTheRetractorPressesTheBrain) {
  const Procedure p = runProcedure("scenes/craniotomy.json", "cran_cut", "");
  EXPECT_GE(p.cut.parts, 2) << p.run.output;
  std::smatch m;
  ASSERT_TRUE(std::regex_search(p.run.output, m, std::regex(R"((\d+) tets, (\d+) nodes; stats)"))) << p.run.output;
  const int tets = std::stoi(m[1]);
  // A flap, not the head: a few percent of the body.
  EXPECT_LT(p.liftedTets, tets / 5) << p.run.output;
  EXPECT_GT(p.liftedTets, tets / 100) << p.run.output;
  // The flap comes off as one part: the cut adds exactly one part to those of the head at rest
  // (TetGen leaves the gap between skull and brain empty, so the brain held at its stem is a
  // part of its own), the parts hold every tet (chips the saw leaves are fragments, removed and
  // reported), and the lifted part is all of the flap.
  ASSERT_FALSE(p.stats.rows.empty());
  const int partsAtRest = int(p.stats.rows.front().at("parts"));
  ASSERT_TRUE(std::regex_search(p.run.output, m, std::regex(R"(parts \(tets\): ([\d, ]+)\n)"))) << p.run.output;
  std::vector<int> sizes;
  const std::string list = m[1];
  const std::regex number(R"(\d+)");
  for (std::sregex_iterator it(list.begin(), list.end(), number), end; it != end; ++it) sizes.push_back(std::stoi(it->str()));
  EXPECT_EQ(int(sizes.size()), partsAtRest + 1) << p.run.output;
  EXPECT_EQ(std::accumulate(sizes.begin(), sizes.end(), 0), tets) << p.run.output;
  EXPECT_EQ(std::count(sizes.begin(), sizes.end(), p.liftedTets), 1) << p.run.output;
  // The retractor touches nothing before the flap is gone, and presses once it is down in the
  // opening (its last keyframes hold it inside the skull's cavity, below the bone).
  for (const auto& row : p.stats.rows)
    if (row.at("lifted") == 0) {
      EXPECT_EQ(row.at("tool0_force"), 0.0) << "at t = " << row.at("time");
    }
  EXPECT_GT(p.stats.rows.back().at("tool0_force"), 0.0) << p.run.output;
  EXPECT_GT(p.stats.rows.back().at("tool0_nodes"), 0.0);
  // The FEM's solver is reported per frame: it iterates, within its cap, and its residual is a
  // finite relative residual.
  for (const auto& row : p.stats.rows) {
    if (row.at("step") == 0) continue;
    EXPECT_GE(row.at("cg_iterations"), 1.0) << "at t = " << row.at("time");
    EXPECT_LE(row.at("cg_iterations"), 100000.0);
    EXPECT_GE(row.at("cg_residual"), 0.0);
    EXPECT_TRUE(std::isfinite(row.at("cg_residual")));
  }
}

TEST(Craniotomy, SimulationOfTheUncutHeadStaysFinite) {
  const auto out = scratch("cran_sim");
  const CliRun r = run("simulate " + source("scenes/craniotomy.json") + " -o " + out.string() + " --steps 10 --frame-every 10 --no-png");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("10 steps"), std::string::npos) << r.output;
}

}  // namespace
