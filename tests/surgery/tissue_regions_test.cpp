// surgery::dominantPrimitive / assignTissueRegions (materialFromPrimitive) against the tissue
// geometry: sample points inside each tissue of the craniotomy (its named subtrees' iso
// surfaces) and check that the primitive chosen carries that tissue's material; and every tet
// of a body gets the region of the primitive dominating at its centroid.
#include "test_bodies.h"

#include "blobvk/blobtree/evaluate.h"
#include "blobvk/blobtree/scene_json.h"
#include "blobvk/surgery/tissue_regions.h"

#include <glm/vec3.hpp>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>
#include <string>

namespace {

using namespace blobvk;

std::string source(const std::string& rel) { return std::string(BLOBVK_SOURCE_DIR) + "/" + rel; }

// materialFromPrimitive gives a tet the material of the primitive whose own field is largest at
// its centroid. Sample points inside each tissue (by the tissue's own geometry: the scene's
// named subtrees) and check that the dominating primitive carries that tissue's material.
TEST(TissueRegions, EachCraniotomyTissueGetsItsOwnMaterial) {
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
    return materials[surgery::dominantPrimitive(all, {p.x, p.y, p.z})]["E"].get<double>();
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


// Two point primitives: the tets on each side of the mid plane take that side's primitive.
TEST(TissueRegions, EachTetTakesThePrimitiveDominatingAtItsCentroid) {
  const blobtree::Program two = blobtree::compile(blobtree::parseSceneJson(
      R"({"blobvk": 1, "root": {"type": "blend", "children": [
           {"type": "point", "centre": [-0.3, 0, 0], "support": 1},
           {"type": "point", "centre": [0.3, 0, 0], "support": 1}]}})", "two").root);
  mesh::TetMesh box = blobvk::testing::voxelBox(0.5, 0.1);
  surgery::assignTissueRegions(two, box);
  ASSERT_EQ(box.regions.size(), box.tets.size());
  std::size_t left = 0, right = 0;
  for (std::uint32_t t = 0; t < box.tets.size(); ++t) {
    const double x = blobvk::testing::restCentroid(box, t).x;
    if (std::abs(x) < 1e-9) continue;  // on the mid plane: a tie
    EXPECT_EQ(box.regions[t], x < 0 ? 0u : 1u) << "tet " << t << " at x = " << x;
    ++(x < 0 ? left : right);
  }
  EXPECT_GT(left, 100u);
  EXPECT_GT(right, 100u);
  EXPECT_THROW(surgery::dominantPrimitive(blobtree::Program{}, {0, 0, 0}), std::invalid_argument);
}

}  // namespace
