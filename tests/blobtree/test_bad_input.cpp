// The bad-input catalogue: every malformed file in tests/data/bad/ must be refused with a
// SceneError that names the file, the exact JSON pointer or line, and the problem.
#include "blobvk/blobtree/scene_error.h"
#include "blobvk/blobtree/scene_blob.h"
#include "blobvk/blobtree/scene_io.h"
#include "blobvk/blobtree/scene_json.h"
#include "blobvk/blobtree/tree.h"

#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <set>
#include <string>

using namespace blobvk::blobtree;

namespace {

const std::string kBad = BLOBVK_SOURCE_DIR "/tests/data/bad/";

struct BadCase {
  const char* file;
  const char* location;  // JSON pointer or "line N" (derived by reading the file)
  const char* phrase;    // must appear in the problem
};

const BadCase kCases[] = {
    // JSON: syntax
    {"j01_missing_brace.json", "line 3, column 1", "unexpected end of input"},
    {"j02_trailing_comma.json", "line 3, column 28", "malformed JSON"},
    {"j36_empty.json", "line 1, column 1", "unexpected end of input"},
    // JSON: structure and types
    {"j03_not_object.json", "/", "expected the scene object at the top level, got an array"},
    {"j04_missing_version.json", "/", "missing required key 'blobvk'"},
    {"j05_wrong_version.json", "/blobvk", "unsupported format version 2"},
    {"j06_missing_root.json", "/", "missing required key 'root'"},
    {"j07_unknown_top_key.json", "/roots", "unknown key 'roots'"},
    {"j08_unknown_type.json", "/root/type", "unknown node type 'sphere'"},
    {"j09_missing_type.json", "/root", "missing required key 'type'"},
    {"j10_color_spelling.json", "/root/color", "did you mean 'colour'"},
    {"j11_radius_string.json", "/root/children/1/radius", "expected a number, got a string"},
    {"j16_short_vector.json", "/root/centre", "expected an array of 3 numbers, got 2 elements"},
    {"j17_vector_element_string.json", "/root/centre/1", "expected a number, got a string"},
    {"j42_id_not_string.json", "/root/id", "expected a string, got a number"},
    {"j43_children_not_array.json", "/root/children", "expected an array of nodes, got an object"},
    {"j45_slash_key.json", "/root/a~1b~0c", "unknown key 'a/b~c'"},
    {"j48_scale_bool.json", "/root/transform/scale", "got a boolean"},
    // JSON: values
    {"j12_negative_radius.json", "/root/children/0/radius", "radius must be > 0, got -1"},
    {"j13_zero_support.json", "/root/support", "support must be > 0, got 0"},
    {"j14_huge_number.json", "/root/centre/1", "out of range"},
    {"j15_overflow_number.json", "line 1, column 58", "number overflow"},
    {"j23_zero_axis.json", "/root/axis", "cannot be normalised"},
    {"j24_zero_quaternion.json", "/root/transform/rotate/quaternion", "cannot be normalised"},
    {"j25_zero_scale.json", "/root/transform/scale/1", "scale must be > 0"},
    {"j26_ricci_power_zero.json", "/root/power", "power must be > 0"},
    {"j51_ricci_power_small.json", "/root/power", "power 0.001 is below 0.1: the Ricci blend would overflow a float"},
    {"j52_tiny_support.json", "/root/support", "support 1e-300 is below 1e-06"},
    {"j27_bad_axis_name.json", "/root/axis", "unknown axis 'w'"},
    {"j28_same_axes.json", "/root/taperAxis", "must differ"},
    {"j35_colour_range.json", "/root/colour/0", "within [0, 1]"},
    {"j37_triangle_collinear.json", "/root/corners", "collinear"},
    {"j38_bend_zero_rate.json", "/root/rate", "non-zero"},
    {"j46_bend_range.json", "/root/hi", "lo < hi"},
    {"j47_cube_negative.json", "/root/halfExtents/1", "must be >= 0"},
    {"j40_rotate_both.json", "/root/transform/rotate", "not both"},
    // JSON: arity
    {"j18_warp_two_children.json", "/root/children", "exactly 1 child, got 2"},
    {"j19_difference_one_child.json", "/root/children", "at least 2 children, got 1"},
    {"j20_union_no_children.json", "/root/children", "at least 1 child, got 0"},
    {"j21_blend_missing_children.json", "/root", "missing required key 'children'"},
    {"j22_primitive_with_children.json", "/root/children", "cannot have children"},
    // JSON: instancing
    {"j29_instance_unknown.json", "/root/children/1/of", "unknown id 'b'"},
    {"j30_instance_self.json", "/root/children/0/children/1/of", "contains itself"},
    {"j31_instance_ambiguous.json", "/root/children/2/of", "defined twice"},
    {"j39_definition_without_id.json", "/definitions/0", "needs an \"id\""},
    {"j44_mutual_instances.json", "/definitions/1/children/0/of", "'a' contains itself"},
    // Cycles made of instances only (no operator between them) once recursed until the stack ran out.
    {"j49_instance_of_itself.json", "/root/of", "instance of 'a' contains itself"},
    {"j50_instances_only_cycle.json", "/definitions/0/of", "contains itself"},
    // JSON: camera and grid
    {"j32_grid_both.json", "/grid", "not both"},
    {"j33_grid_bounds.json", "/grid/bounds/hi/0", "lo < hi"},
    {"j34_camera_fov.json", "/camera/fovYDeg", "field of view"},
    {"j41_resolution_fraction.json", "/grid/resolution", "expected an integer"},
    {"j53_resolution_huge.json", "/grid/resolution", "resolution must be within [1, 16384], got 18446744073709551615"},
    // legacy .blob
    {"b01_no_global.blob", "line 4", "no [Global] section"},
    {"b02_no_rootids.blob", "line 5", "has no RootIDs"},
    {"b03_unknown_root.blob", "line 6", "unknown node id '7'"},
    {"b04_dangling_child.blob", "line 4", "unknown node id '9'"},
    {"b05_cycle.blob", "line 9", "cycle: node '0' contains itself"},
    {"b06_unknown_op.blob", "line 3", "unknown operator type 'MORPH'"},
    {"b07_unknown_prim.blob", "line 3", "unknown primitive type 'SPHERE'"},
    {"b08_bad_number.blob", "line 4", "'abc' is not a number"},
    {"b09_negative_radius.blob", "line 6", "radius must be > 0, got -2"},
    {"b10_short_vector.blob", "line 4", "position needs 3 numbers, got 2"},
    {"b11_duplicate_id.blob", "line 5", "duplicate node id '1' (first at line 1)"},
    {"b12_missing_equals.blob", "line 4", "expected 'key=value'"},
    {"b13_key_before_section.blob", "line 1", "before any [section]"},
    {"b14_warp_two_children.blob", "line 6", "exactly 1 child, got 2"},
    {"b15_difference_one_child.blob", "line 4", "at least 2 children, got 1"},
    {"b16_zero_quaternion.blob", "line 4", "cannot be normalised"},
    {"b17_instance_cycle.blob", "line 13", "cycle: node '0' contains itself"},
    {"b18_children_count.blob", "line 4", "ChildrenCount=3 but 2"},
    {"b19_huge_value.blob", "line 4", "out of range"},
    {"b20_unclosed_header.blob", "line 1", "missing its ']'"},
    {"b21_layers.blob", "line 6", "NumLayers=1"},
    {"b22_range_reversed.blob", "line 5", "first <= last"},
    {"b23_missing_radius.blob", "line 1", "is missing radius="},
    {"b24_isoperator_bad.blob", "line 2", "must be 0 or 1"},
    {"b25_nan.blob", "line 4", "not finite"},
    {"b26_null_root.blob", "line 3", "NULL primitive may only pad"},
    {"b27_ricci_power.blob", "line 4", "power must be > 0"},
    {"b28_ricci_power_small.blob", "line 4", "power 0.0001 is below 0.1"},
    {"b29_two_globals.blob", "line 12", "[Global] given twice (first at line 5)"},
    {"b30_contradicting_types.blob", "line 4", "SkeletonType=LINE contradicts PrimitiveType=POINT (line 3)"},
};

class BadInput : public ::testing::TestWithParam<BadCase> {};

}  // namespace

TEST_P(BadInput, IsRefusedWithLocationAndReason) {
  const BadCase& c = GetParam();
  const std::string path = kBad + c.file;
  try {
    loadScene(path);
    FAIL() << c.file << " was accepted";
  } catch (const SceneError& e) {
    const std::string what = e.what();
    EXPECT_EQ(e.file(), path);
    EXPECT_EQ(e.location(), c.location) << what;
    EXPECT_NE(e.problem().find(c.phrase), std::string::npos) << what;
    EXPECT_EQ(what, path + ": " + c.location + ": " + e.problem());
    EXPECT_EQ(what.find('\n'), std::string::npos) << "one line";
  }
}

INSTANTIATE_TEST_SUITE_P(Catalogue, BadInput, ::testing::ValuesIn(kCases), [](const auto& info) {
  std::string name = info.param.file;
  for (char& ch : name)
    if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
  return name;
});

TEST(BadInputCatalogue, EveryFileIsListedOnce) {
  std::set<std::string> listed;
  for (const BadCase& c : kCases) EXPECT_TRUE(listed.insert(c.file).second) << c.file;
  std::set<std::string> present;
  for (const auto& entry : std::filesystem::directory_iterator(kBad)) present.insert(entry.path().filename().string());
  EXPECT_EQ(listed, present);
  EXPECT_GE(listed.size(), 30u);
}

// Inputs too large to ship as files, built in memory: each is refused with one line before it
// can exhaust memory.
namespace {
// A chain of definitions, each instancing the one below twice, whose first node has a long id:
// 2^levels copies of the id after instancing, in a text of a few hundred kilobytes.
std::string doublingInstances(std::size_t idLength, int levels) {
  const std::string big(idLength, 'x');
  std::string defs = R"({"type":"point","id":"d0"},{"type":"blend","id":")" + big +
                     R"(","children":[{"type":"instance","of":"d0"}]})";
  std::string below = big;
  for (int i = 1; i <= levels; ++i) {
    std::string id = std::to_string(i);
    id.insert(id.begin(), 'e');  // not "e" + ...: GCC 12 warns of a false overlap (-Wrestrict)
    defs += R"(,{"type":"blend","id":")" + id + R"(","children":[{"type":"instance","of":")" + below +
            R"("},{"type":"instance","of":")" + below + R"("}]})";
    below = id;
  }
  return R"({"blobvk":1,"definitions":[)" + defs + R"(],"root":{"type":"instance","of":")" + below + R"("}})";
}
}  // namespace

TEST(BadInputGenerated, LongIdsInstancedManyTimesAreRefusedByTheirBytes) {
  // 2^12 copies of a 200,000-character id: 800 MB of ids from 4,097 nodes, far inside the
  // node limit.
  try {
    parseSceneJson(doublingInstances(200000, 12), "laughs.json");
    FAIL() << "accepted";
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("the ids of the nodes after instancing take more than 64 MiB"), std::string::npos)
        << e.what();
    EXPECT_EQ(std::string(e.location()).rfind("/definitions/", 0), 0u) << e.what();
  }
  // The same chain with short ids is a model (8,193 nodes).
  EXPECT_NO_THROW(parseSceneJson(doublingInstances(8, 12), "small.json"));
}

// Definitions are not the model: each is held to the model's node limit on its own, and only the
// root's expansion counts towards the model's. A chain of 20 doubling definitions holds 6.3
// million nodes together; its last one alone 3.1 million, which the root may instance (a model
// under the limit that counting the definitions together refused).
TEST(BadInputGenerated, DefinitionsCountAsModelsOfTheirOwn) {
  // (The reader expands each definition once: about 2 GB and 3 s in a release build.)
  const Scene used = parseSceneJson(doublingInstances(8, 20), "chain.json");
  EXPECT_EQ(treeStats(used.root).primitives, std::size_t(1) << 20);
}

TEST(BadInputGenerated, LegacyNodesSharedManyTimesAreRefusedByTheirIdBytes) {
  // [BLOBNODE i] blends node i + 1 twice; the leaf's id is 100,000 digits long.
  std::string leaf(100000, '0');
  leaf[0] = '1';
  std::string text;
  const int levels = 12;
  for (int i = 0; i < levels; ++i) {
    const std::string next = i + 1 < levels ? std::to_string(i + 1) : leaf;
    text += "[BLOBNODE " + std::to_string(i) + "]\nIsOperator=1\nOperatorType=BLEND\nChildrenIDs=(" + next + ", " +
            next + ")\n\n";
  }
  text += "[BLOBNODE " + leaf + "]\nIsOperator=0\nPrimitiveType=POINT\n\n[Global]\nRootIDs=(0)\n";
  try {
    parseSceneBlob(text, "dag.blob");
    FAIL() << "accepted";
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("the ids of the nodes after instancing take more than 64 MiB"), std::string::npos)
        << e.what();
  }
}

TEST(BadInputGenerated, EndlessFilesAreRefusedBySize) {
  // /dev/zero under a scene name: read up to the size limit, then refused with the file's name.
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / ("blobvk_endless_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  for (const char* name : {"zero.json", "zero.blob"}) {
    const std::filesystem::path link = dir / name;
    std::filesystem::remove(link);
    std::filesystem::create_symlink("/dev/zero", link);
    try {
      loadScene(link.string());
      FAIL() << name << " accepted";
    } catch (const SceneError& e) {
      EXPECT_EQ(std::string(e.what()), link.string() + ": more than 256 MiB: too large for a scene file");
    }
  }
  std::filesystem::remove_all(dir);
}
