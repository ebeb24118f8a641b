// The thesis' evaluation scenes (scenes/eggshell_sim.json, scenes/craniotomy.json) run end to end
// through the blobvk binary, as a user would: the cut separates a part, the cut mesh passes its
// self-check, the simulation stays finite (the CLI fails on NaN) and the freed part moves away.
// The craniotomy's tissue materials (materialFromPrimitive) are checked against the tissue
// geometry, with the library's own evaluator.
#include "tests/cli/run_cli.h"
#include "blobtree/evaluate.h"
#include "blobtree/scene_json.h"
#include "mesh/io.h"

#include <glm/common.hpp>
#include <glm/vec3.hpp>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <array>
#include <map>
#include <cstdio>
#include <filesystem>
#include <fstream>
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

// "cut: 43 events in 625.5 ms, 3 parts; self-check ok"
struct CutLine {
  int events = -1, parts = -1;
  bool selfCheckOk = false;
};
CutLine parseCut(const std::string& output) {
  CutLine c;
  std::smatch m;
  if (std::regex_search(output, m, std::regex(R"(cut: (\d+) events in [0-9.]+ ms, (\d+) parts; self-check (\S+))"))) {
    c.events = std::stoi(m[1]);
    c.parts = std::stoi(m[2]);
    c.selfCheckOk = m[3] == "ok";
  }
  return c;
}

struct Box {
  glm::dvec3 lo{1e30}, hi{-1e30};
};
Box boundsOf(const std::filesystem::path& ply) {
  const mesh::TriMesh m = mesh::readPly(ply.string());
  Box b;
  for (const auto& p : m.positions) {
    b.lo = glm::min(b.lo, glm::dvec3(p.x, p.y, p.z));
    b.hi = glm::max(b.hi, glm::dvec3(p.x, p.y, p.z));
  }
  return b;
}

std::filesystem::path lastFrame(const std::filesystem::path& dir) {
  std::filesystem::path last;
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    if (e.path().extension() == ".ply" && (last.empty() || e.path().filename() > last.filename())) last = e.path();
  }
  return last;
}

TEST(Eggshell, BottomCapIsCutOffAndFallsAway) {
  const auto out = scratch("egg_cut");
  const CliRun r = run("cut " + source("scenes/eggshell_sim.json") + " -o " + out.string() + " --steps 30 --frame-every 30 --no-png");
  ASSERT_EQ(r.status, 0) << r.output;
  const CutLine cut = parseCut(r.output);
  EXPECT_GE(cut.parts, 2) << r.output;  // the cap and the rest of the shell
  EXPECT_TRUE(cut.selfCheckOk) << r.output;
  EXPECT_GT(cut.events, 10);
  // The egg is held at its top; the freed cap drops under gravity, so the lowest point sinks.
  const Box before = boundsOf(out / "frame_00000.ply"), after = boundsOf(lastFrame(out));
  EXPECT_LT(after.lo.y, before.lo.y - 0.12) << "the cap did not fall: " << before.lo.y << " -> " << after.lo.y;
}

TEST(Eggshell, ProbePressesTheShellWithoutNaN) {
  const auto out = scratch("egg_sim");
  const CliRun r = run("simulate " + source("scenes/eggshell_sim.json") + " -o " + out.string() + " --steps 30 --frame-every 30 --no-png");
  ASSERT_EQ(r.status, 0) << r.output;
  std::smatch m;
  ASSERT_TRUE(std::regex_search(r.output, m, std::regex(R"(max tool force ([0-9.e+-]+) N)"))) << r.output;
  EXPECT_GT(std::stod(m[1]), 0.0) << "the probe never touched the shell";
}

TEST(Craniotomy, BoneFlapSeparatesAndLeavesTheSkull) {
  const auto out = scratch("cran_cut");
  const CliRun r = run("cut " + source("scenes/craniotomy.json") + " -o " + out.string() + " --steps 40 --frame-every 40 --no-png");
  ASSERT_EQ(r.status, 0) << r.output;
  const CutLine cut = parseCut(r.output);
  // Before the cut the head is two bodies (scalp+skull, CSF+brain, apart across the epidural
  // gap); the flap makes a third.
  EXPECT_GE(cut.parts, 3) << r.output;
  EXPECT_TRUE(cut.selfCheckOk) << r.output;
  const Box before = boundsOf(out / "frame_00000.ply"), after = boundsOf(lastFrame(out));
  EXPECT_GT(after.hi.y, before.hi.y + 0.3) << "the flap did not leave: " << before.hi.y << " -> " << after.hi.y;
  // Only the flap leaves: the clamped skull keeps its extent sideways and below.
  EXPECT_NEAR(after.lo.y, before.lo.y, 0.02);
  EXPECT_NEAR(after.lo.x, before.lo.x, 0.02);
  EXPECT_NEAR(after.hi.z, before.hi.z, 0.02);
}

TEST(Craniotomy, SimulationOfTheUncutHeadStaysFinite) {
  const auto out = scratch("cran_sim");
  const CliRun r = run("simulate " + source("scenes/craniotomy.json") + " -o " + out.string() + " --steps 10 --frame-every 10 --no-png");
  ASSERT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("10 steps"), std::string::npos) << r.output;
}

// materialFromPrimitive gives a tet the material of the primitive whose own field is largest at
// its centroid. Sample points inside each tissue (by the tissue's own geometry: the scene's
// named subtrees) and check that the dominating primitive carries that tissue's material.
TEST(Craniotomy, EachTissueGetsItsOwnMaterial) {
  std::ifstream in(source("scenes/craniotomy.json"));
  std::stringstream text;
  text << in.rdbuf();
  const nlohmann::json scene = nlohmann::json::parse(text.str());
  const auto& materials = scene["simulation"]["materials"];
  const blobtree::Program all = blobtree::compile(blobtree::parseSceneJson(text.str(), "craniotomy").root);
  ASSERT_EQ(all.primitives.size(), materials.size());

  // Tissue membership from the geometry alone: the ellipsoid layers' iso surfaces.
  auto program = [](const nlohmann::json& node) {
    return blobtree::compile(blobtree::parseSceneJson(nlohmann::json{{"blobvk", 1}, {"root", node}}.dump(), "tissue").root);
  };
  const auto& shell = scene["root"]["children"][0];  // difference(union(scalp, skull outer), skull inner)
  const auto& intracranial = scene["root"]["children"][1];
  const blobtree::Program skullOuter = program(shell["children"][0]["children"][1]);
  const blobtree::Program shellProgram = program(shell);
  const blobtree::Program brain = program(intracranial["children"][1]);
  const blobtree::Program head = program(scene["root"]);
  const double scalpE = materials[0]["E"], boneE = materials[1]["E"], csfE = materials[3]["E"], brainE = materials[4]["E"];

  auto dominantE = [&](const glm::vec3& p) {
    std::size_t best = 0;
    float bestField = -1;
    for (std::size_t i = 0; i < all.primitives.size(); ++i) {
      const float f = blobtree::primitiveField(all, all.primitives[i], p);
      if (f > bestField) bestField = f, best = i;
    }
    return materials[best]["E"].get<double>();
  };
  std::map<std::string, std::pair<int, int>> counts;  // tissue -> (right, total)
  const float step = 0.02f;
  for (float x = -1; x <= 1; x += step)
    for (float y = -1; y <= 1; y += step)
      for (float z = -1.1f; z <= 1.1f; z += step) {
        const glm::vec3 p(x, y, z);
        if (blobtree::evaluate(head, p) < 0.5f) continue;
        std::string tissue;
        double expected;
        if (blobtree::evaluate(shellProgram, p) >= 0.5f) {
          const bool bone = blobtree::evaluate(skullOuter, p) >= 0.5f;
          tissue = bone ? "skull" : "scalp";
          expected = bone ? boneE : scalpE;
        } else {
          const bool isBrain = blobtree::evaluate(brain, p) >= 0.5f;
          tissue = isBrain ? "brain" : "CSF";
          expected = isBrain ? brainE : csfE;
        }
        auto& c = counts[tissue];
        c.first += dominantE(p) == expected;
        ++c.second;
      }
  for (const char* tissue : {"scalp", "skull", "CSF", "brain"}) {
    const auto [right, total] = counts[tissue];
    ASSERT_GT(total, 100) << tissue;
    const double fraction = double(right) / total;
    std::printf("%-6s %6d samples, %.1f %% get its material\n", tissue, total, 100 * fraction);
    EXPECT_GT(fraction, 0.8) << tissue;
  }
}

}  // namespace
