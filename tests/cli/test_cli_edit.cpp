// `blobvk edit`: frames after each edit of a script, checked against an independent path (the
// edited scene written by the test itself and meshed by `blobvk mesh` from scratch: the PLY
// bytes must be equal), PNG frames decoded by libpng, and bad scripts (one line naming the file,
// the JSON pointer and the problem).
#include "cli_files.h"
#include "run_cli.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

namespace {

using namespace blobvk::testing;
namespace fs = std::filesystem;
using Json = nlohmann::json;

fs::path dir(const std::string& name) {
  const fs::path d = scratchDir() / name;
  fs::create_directories(d);
  return d;
}

void writeJson(const fs::path& path, const Json& j) { std::ofstream(path) << j.dump(2); }

// random128.json with a fixed grid (bounds and cell size), so `blobvk mesh` of an edited copy
// samples the same points as the edit session.
Json fixedGridScene() {
  Json scene = Json::parse(fileBytes(sourcePath("scenes/random128.json")));
  scene["grid"] = {{"cellSize", 0.25}, {"bounds", {{"lo", {-6, -6, -6}}, {"hi", {6, 6, 6}}}}};
  return scene;
}

// Three edits of fixedGridScene() (move and recolour, add, remove) as a script, and the scene
// after each, edited by this test itself: the independent path a frame is checked against.
struct ScriptedEdits {
  Json script;
  std::vector<Json> steps;  // the scene as loaded, then after each edit
};
ScriptedEdits threeEdits() {
  ScriptedEdits e;
  const Json scene = fixedGridScene();
  const Json point = {{"type", "point"}, {"centre", {0.5, 0.5, 0.5}}, {"support", 2.0}, {"colour", {1, 0, 0}}};
  e.script = {{"blobvk_edits", 1},
              {"edits",
               {{{"path", {5}}, {"set", {{"centre", {1.0, -0.5, 0.25}}, {"colour", {0.1, 0.9, 0.2}}}}},
                {{"path", Json::array()}, {"add", point}, {"at", 0}},
                {{"path", Json::array()}, {"remove", 3}}}}};
  e.steps.push_back(scene);
  Json s = scene;
  s["root"]["children"][5]["centre"] = {1.0, -0.5, 0.25};
  s["root"]["children"][5]["colour"] = {0.1, 0.9, 0.2};
  e.steps.push_back(s);
  s["root"]["children"].insert(s["root"]["children"].begin(), point);
  e.steps.push_back(s);
  s["root"]["children"].erase(s["root"]["children"].begin() + 3);
  e.steps.push_back(s);
  return e;
}

// Each frame `prefix_NN.ply` equals `blobvk mesh` (the cpu backend) of the scene after its edits,
// and the report counts what the frame holds (the PLY header's face count).
void expectFramesEqualFullMeshes(const fs::path& cwd, const std::string& prefix, const ScriptedEdits& e,
                                 const Json& report) {
  for (std::size_t k = 0; k < e.steps.size(); ++k) {
    writeJson(cwd / "step.json", e.steps[k]);
    ASSERT_EQ(runCliSplit("mesh step.json -o full.ply", cwd).status, 0);
    char frame[32];
    std::snprintf(frame, sizeof frame, "%s_%02zu.ply", prefix.c_str(), k);
    EXPECT_EQ(fileBytes(cwd / frame), fileBytes(cwd / "full.ply")) << frame;
    const std::string ply = fileBytes(cwd / frame);
    const auto face = ply.find("element face ");
    ASSERT_NE(face, std::string::npos);
    const Json& row = k == 0 ? report["initial"] : report["edits"][k - 1];
    EXPECT_EQ(std::stoull(ply.substr(face + 13)), row["triangles"].get<std::uint64_t>()) << frame;
  }
  EXPECT_NE(fileBytes(cwd / (prefix + "_00.ply")), fileBytes(cwd / (prefix + "_01.ply")));
}

class CliEdit : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { setenv("LP_NUM_THREADS", "2", 0); }
};

TEST_F(CliEdit, EveryFrameEqualsAFullMeshOfTheEditedScene) {
  const fs::path cwd = dir("edit_frames");
  const ScriptedEdits e = threeEdits();
  ASSERT_GE(e.steps[0]["root"]["children"].size(), 10u);
  writeJson(cwd / "s.json", e.steps[0]);
  writeJson(cwd / "e.json", e.script);
  const CliSplitRun r = runCliSplit("edit s.json e.json -o f_%02d.ply --json", cwd);
  ASSERT_EQ(r.status, 0) << r.err;
  const Json report = Json::parse(r.out);
  ASSERT_EQ(report["edits"].size(), 3u);
  EXPECT_FALSE(report["edits"][0]["full_remesh"].get<bool>());
  EXPECT_LT(report["edits"][0]["mpus_rerun"].get<int>(), report["edits"][0]["mpus"].get<int>());
  expectFramesEqualFullMeshes(cwd, "f", e, report);
}

#ifdef BLOBVK_HAVE_VULKAN  // the sanitizer build has no Vulkan: not registered there
// --backend vk re-runs boxes of bricks on lavapipe under validation; its frames are the CPU's full
// meshes byte for byte (lavapipe computes random128's field as the CPU does).
TEST_F(CliEdit, VulkanBackendFramesEqualFullMeshesOfTheEditedScene) {
  const fs::path cwd = dir("edit_frames_vk");
  const ScriptedEdits e = threeEdits();
  writeJson(cwd / "s.json", e.steps[0]);
  writeJson(cwd / "e.json", e.script);
  const CliSplitRun r =
      runCliSplit("edit s.json e.json -o v_%02d.ply --backend vk --brick-cells 8 --validation --json", cwd);
  ASSERT_EQ(r.status, 0) << r.err;
  const Json report = Json::parse(r.out);
  EXPECT_EQ(report["backend"], "vk");
  EXPECT_EQ(report["device"]["driver_name"], "llvmpipe") << r.out;  // the device that ran it, as in mesh --json
  ASSERT_EQ(report["edits"].size(), 3u);
  const Json& first = report["edits"][0];
  EXPECT_FALSE(first["full_remesh"].get<bool>());
  EXPECT_GT(first["layers_rerun"].get<int>(), 0);
  EXPECT_LT(first["layers_rerun"].get<int>(), first["layers"].get<int>());
  EXPECT_GT(first["bricks_rerun"].get<int>(), 0);
  EXPECT_LT(first["bricks_rerun"].get<int>(), first["bricks"].get<int>());
  EXPECT_TRUE(first["evaluator"] == "stackless" || first["evaluator"] == "specialised") << first["evaluator"];
  for (const char* key : {"remesh_ms", "classify_ms", "extract_ms", "splice_ms", "apply_ms"})
    EXPECT_GT(first[key].get<double>(), 0.0) << key;
  expectFramesEqualFullMeshes(cwd, "v", e, report);
  // Options of the other backend are refused before any work.
  const CliSplitRun wrong = runCliSplit("edit s.json e.json -o w_%02d.ply --brick-cells 8", cwd);
  EXPECT_EQ(wrong.status, 2) << wrong.err;
  EXPECT_NE(wrong.err.find("--backend vk"), std::string::npos) << wrong.err;
  EXPECT_FALSE(fs::exists(cwd / "w_00.ply"));
}
#endif

#ifdef BLOBVK_HAVE_VULKAN  // the sanitizer build has no Vulkan: not registered there
TEST_F(CliEdit, ShippedScriptRunsWithCheckAndWritesPngFrames) {
  const fs::path cwd = dir("edit_png");
  const CliSplitRun r = runCliSplit("edit " + sourcePath("scenes/tower.json") + " " +
                                        sourcePath("scenes/edits/tower_edits.json") +
                                        " -o t_%d.png --resolution 48 --size 96x64 --check",
                                    cwd);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("edit 6/6"), std::string::npos) << r.out;
  for (int k = 0; k <= 6; ++k) {
    const Rgba image = decodePng(fileBytes(cwd / ("t_" + std::to_string(k) + ".png")));
    EXPECT_EQ(image.width, 96u) << k;
    EXPECT_EQ(image.height, 64u) << k;
  }
  // Storey 2 turned by edit 3 shows.
  EXPECT_GT(decodePng(fileBytes(cwd / "t_3.png")).pixelsDifferingFrom(decodePng(fileBytes(cwd / "t_2.png")), 8), 20u);
}
#endif

TEST_F(CliEdit, BadScriptsNameFilePointerAndProblem) {
  const fs::path cwd = dir("edit_bad");
  writeJson(cwd / "s.json", fixedGridScene());
  const auto run = [&](const std::string& script) {
    std::ofstream(cwd / "bad.json") << script;
    return runCliSplit("edit s.json bad.json -o out_%d.ply", cwd);
  };
  // One error line naming the file, the pointer and the problem; no frame after the first.
  const auto expectRefused = [&](const std::string& script, const std::string& expected) {
    const CliSplitRun r = run(script);
    EXPECT_EQ(r.status, 1) << script;
    EXPECT_NE(r.err.find(expected), std::string::npos) << script << "\n" << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_FALSE(fs::exists(cwd / "out_1.ply")) << script;
  };
  const std::pair<std::string, std::string> cases[] = {
      {"{\"blobvk_edits\": 1, \"edits\": [", "bad.json: line 1, column 31: malformed JSON"},
      {"{\"edits\": []}", "bad.json: /: missing key \"blobvk_edits\""},
      {"{\"blobvk_edits\": 2, \"edits\": [{}]}", "bad.json: /blobvk_edits: unsupported format version 2"},
      {"{\"blobvk_edits\": 1, \"edits\": [{\"node\": \"nope\", \"remove\": 0}]}", "bad.json: /edits/0/node: no node with id"},
      {"{\"blobvk_edits\": 1, \"edits\": [{\"path\": [200], \"set\": {\"support\": 2}}]}",
       "bad.json: /edits/0/path/0: the node at [] has 128 children, no child 200"},
      {"{\"blobvk_edits\": 1, \"edits\": [{\"path\": [0], \"set\": {\"support\": -1}}]}", "bad.json: /edits/0/set/support:"},
      {"{\"blobvk_edits\": 1, \"edits\": [{\"path\": [0], \"set\": {\"radius\": 1}}]}", "bad.json: /edits/0/set/radius:"},
      {"{\"blobvk_edits\": 1, \"edits\": [{\"path\": [], \"add\": {\"type\": \"blob\"}}]}", "bad.json: /edits/0/add/type: unknown node type"},
      {"{\"blobvk_edits\": 1, \"edits\": [{\"path\": [0], \"remove\": 0}]}", "bad.json: /edits/0/remove: the node at [0] has 0 children"},
      {"{\"blobvk_edits\": 1, \"edits\": [{\"path\": [], \"set\": {\"type\": \"point\"}}]}",
       "bad.json: /edits/0/set/type: the node at [] cannot change between primitive, operator and warp"},
      {"{\"blobvk_edits\": 1, \"edits\": [{\"path\": [0], \"set\": {\"type\": \"blend\"}}]}",
       "bad.json: /edits/0/set/type: the node at [0] cannot change between primitive, operator and warp"},
      {"{\"blobvk_edits\": 1, \"edits\": [{\"path\": [], \"move\": 1}]}", "bad.json: /edits/0/move: unknown key"},
      {"{\"blobvk_edits\": 1, \"edits\": [{\"path\": [0], \"set\": {\"support\": 2, \"support\": 3}}]}",
       "bad.json: /edits/0/set/support: key \"support\" appears twice in one object"},
      {"{\"blobvk_edits\": 1, \"edits\": [{\"path\": [0], \"node\": \"x\", \"remove\": 0}]}", "bad.json: /edits/0: name the node by exactly one"},
  };
  for (const auto& [script, expected] : cases) expectRefused(script, expected);
  // Ids name one node: an id the scene repeats is refused as a name, and an edit may not give a
  // second node an id the tree already has.
  Json twice = fixedGridScene();
  twice["root"]["children"][0]["id"] = "a";
  twice["root"]["children"][1]["id"] = "b";
  twice["root"]["children"][2]["id"] = "b";
  writeJson(cwd / "s.json", twice);
  const std::pair<std::string, std::string> idCases[] = {
      {"{\"blobvk_edits\": 1, \"edits\": [{\"node\": \"b\", \"set\": {\"support\": 2}}]}",
       "bad.json: /edits/0/node: the id 'b' names more than one node ([1] and [2]): name the node by \"path\""},
      {"{\"blobvk_edits\": 1, \"edits\": [{\"path\": [], \"add\": {\"type\": \"point\", \"id\": \"a\"}}]}",
       "bad.json: /edits/0/add/id: the node at [0] already has the id 'a'"},
      {"{\"blobvk_edits\": 1, \"edits\": [{\"path\": [], \"add\": {\"type\": \"blend\", \"children\": [{\"type\": \"point\", \"id\": \"c\"}, "
       "{\"type\": \"point\", \"id\": \"c\"}]}}]}",
       "bad.json: /edits/0/add/children/1/id: the id 'c' is given twice in this edit"},
      {"{\"blobvk_edits\": 1, \"edits\": [{\"path\": [3], \"set\": {\"id\": \"a\"}}]}",
       "bad.json: /edits/0/set/id: the node at [0] already has the id 'a'"},
  };
  for (const auto& [script, expected] : idCases) expectRefused(script, expected);
  // Setting a node's own id again, and naming a node by an id it alone has, still work.
  const CliSplitRun same = run("{\"blobvk_edits\": 1, \"edits\": [{\"node\": \"a\", \"set\": {\"id\": \"a\", \"support\": 2}}]}");
  EXPECT_EQ(same.status, 0) << same.err;
  // --size is the size of PNG frames: with mesh frames it is refused, not ignored.
  const CliSplitRun size = runCliSplit("edit s.json bad.json -o out_%d.ply --size 64x64", cwd);
  EXPECT_EQ(size.status, 2);
  EXPECT_NE(size.err.find("--size is the size of PNG frames"), std::string::npos) << size.err;
  // The frame pattern is a usage error, found before any work.
  const CliSplitRun pattern = runCliSplit("edit s.json bad.json -o out.ply", cwd);
  EXPECT_EQ(pattern.status, 2);
  EXPECT_NE(pattern.err.find("needs one %d"), std::string::npos) << pattern.err;
}

}  // namespace
