// surgery::parseSimulationConfig against the library's own rules: a value the FEM would refuse
// later (after the tetrahedralization, without a file or place) is refused when the section is
// read, at its pointer; a switch takes true or false only.
#include "blobvk/blobtree/scene_error.h"
#include "blobvk/fem/tool.h"
#include "blobvk/surgery/scene_config.h"
#include "scene_error_of.h"

#include <gtest/gtest.h>

#include <string>

namespace blobvk::surgery {
namespace {

blobtree::SceneError configError(const std::string& simulation) {
  return sceneErrorOf([&] { (void)parseSimulationConfig(simulation, "scene.json"); }, simulation);
}

std::string toolWith(const std::string& keys) {
  return R"({"tools": [{)" + keys + R"(, "path": [{"t": 0, "position": [0, 0, 0]}]}]})";
}

TEST(SimulationConfig, ToolValuesTheSimulationRefusesAreRefusedWhenRead) {
  blobtree::SceneError e = configError(toolWith(R"("stiffness": 0)"));
  EXPECT_EQ(e.location(), "/simulation/tools/0/stiffness");
  EXPECT_NE(e.problem().find("stiffness must be > 0"), std::string::npos) << e.what();
  e = configError(toolWith(R"("shape": "box", "halfExtents": [0.1, -0.1, 0.1])"));
  EXPECT_EQ(e.location(), "/simulation/tools/0/halfExtents/1");
  EXPECT_NE(e.problem().find("halfExtents must be >= 0"), std::string::npos) << e.what();
  // What the reader accepts, the library accepts too (the independent check: fem::validateTool).
  const SimulationConfig ok = parseSimulationConfig(toolWith(R"("shape": "box", "halfExtents": [0, 0.1, 0.1], "stiffness": 1e-3)"),
                                                    "scene.json");
  ASSERT_EQ(ok.settings.tools.size(), 1u);
  EXPECT_NO_THROW(fem::validateTool(ok.settings.tools[0], 0));
}

TEST(SimulationConfig, SwitchesTakeTrueOrFalseOnly) {
  for (const std::string value : {"1", "\"yes\"", "null"}) {
    const blobtree::SceneError e = configError(R"({"tetgen": {"keepSurface": )" + value + "}}");
    EXPECT_EQ(e.location(), "/simulation/tetgen/keepSurface") << value;
    EXPECT_NE(e.problem().find("expected true or false"), std::string::npos) << e.what();
  }
  EXPECT_TRUE(parseSimulationConfig(R"({"tetgen": {"keepSurface": true}})", "scene.json").tetgen.keepSurface);
}

}  // namespace
}  // namespace blobvk::surgery
