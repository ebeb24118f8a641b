// surgery::parseBladePath, the reader of `blobvk cut --blade` files: the simulation section's
// blade alone, read by the same rules, each mistake named by the file and its own pointer.
#include "blobvk/blobtree/scene_error.h"
#include "blobvk/surgery/scene_config.h"
#include "scene_error_of.h"

#include <gtest/gtest.h>

#include <string>

namespace blobvk::surgery {
namespace {

blobtree::SceneError bladeError(const std::string& text) {
  return sceneErrorOf([&] { (void)parseBladePath(text, "path.json"); }, text);
}

TEST(BladePathFile, ReadsTheKeyframesOfTheSimulationSection) {
  const auto blade = parseBladePath(R"({"blade": [{"t": 0.05, "a": [0, 1, -1], "b": [0, -1, -1]},
                                                 {"t": 0.2, "a": [0, 1, 1], "b": [0, -1, 1]}]})",
                                    "path.json");
  ASSERT_EQ(blade.size(), 2u);
  EXPECT_EQ(blade[1].time, 0.2);
  EXPECT_EQ(blade[1].a.z, 1.0);
  EXPECT_EQ(blade[0].b.y, -1.0);
  // The same keyframes inside a scene's simulation section.
  const SimulationConfig c = parseSimulationConfig(R"({"blade": [{"t": 0.05, "a": [0, 1, -1], "b": [0, -1, -1]},
                                                                {"t": 0.2, "a": [0, 1, 1], "b": [0, -1, 1]}]})",
                                                   "scene.json");
  ASSERT_EQ(c.blade.size(), 2u);
  EXPECT_EQ(c.blade[1].time, blade[1].time);
}

TEST(BladePathFile, MistakesNameTheFileAndItsOwnPointer) {
  const std::string k0 = R"({"t": 0.1, "a": [0, 1, 0], "b": [0, -1, 0]})";
  blobtree::SceneError e = bladeError(R"({"blade": [)" + k0 + ", " + k0 + "]}");
  EXPECT_EQ(e.file(), "path.json");
  EXPECT_EQ(e.location(), "/blade/1/t");
  EXPECT_NE(e.problem().find("increase strictly"), std::string::npos) << e.what();
  EXPECT_EQ(bladeError(R"({"blade": [)" + k0 + R"(, {"t": 0.2, "a": [0, 1, 0], "b": [0, -1, 0], "c": 1}]})").location(),
            "/blade/1/c");
  EXPECT_EQ(bladeError(R"({"blade": [)" + k0 + ", " + k0 + R"(], "units": "scene"})").location(), "/units");
  EXPECT_EQ(bladeError(R"({"keyframes": []})").location(), "/keyframes");
  EXPECT_EQ(bladeError(R"({})").location(), "/blade");
  EXPECT_EQ(bladeError(R"({"blade": [)" + k0 + "]}").location(), "/blade");  // one keyframe
  // Malformed JSON is placed by line and column, as in a scene (not nlohmann's own text).
  e = bladeError("{\"blade\": [\n");
  EXPECT_EQ(e.location(), "line 2, column 1");
  EXPECT_EQ(e.problem().rfind("malformed JSON: syntax error", 0), 0u) << e.what();
  EXPECT_EQ(std::string(e.what()).find("json.exception"), std::string::npos) << e.what();
  EXPECT_EQ(bladeError("{\"blade\": [1e999]}").location(), "line 1, column 12");
  // A repeated key (a JSON parser would keep one of them without a word).
  e = bladeError(R"({"blade": [{"t": 0.1, "t": 0.3, "a": [0, 1, 0], "b": [0, -1, 0]}, )" + k0 + "]}");
  EXPECT_EQ(e.location(), "/blade/0/t");
  EXPECT_NE(e.problem().find("appears twice"), std::string::npos) << e.what();
  // In a scene the pointer is the section's.
  try {
    (void)parseSimulationConfig(R"({"blade": [)" + k0 + ", " + k0 + "]}", "scene.json");
    ADD_FAILURE() << "no error";
  } catch (const blobtree::SceneError& s) {
    EXPECT_EQ(s.location(), "/simulation/blade/1/t");
  }
}

}  // namespace
}  // namespace blobvk::surgery
