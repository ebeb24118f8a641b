// surgery::writeVtu, read back with libxml2 (an independent XML parser; ParaView is not
// available): the VTK structure (UnstructuredGrid, piece counts), connectivity in range and
// equal to the mesh, offsets and cell types of tetrahedra, and data arrays of the right sizes
// whose values are the mesh's own (displacement = position - rest, region, part).
#include "test_bodies.h"

#include "blobvk/surgery/soft_body.h"
#include "blobvk/surgery/vtu_writer.h"

#include <gtest/gtest.h>
#include <libxml/parser.h>
#include <libxml/tree.h>

#include <cstdlib>
#include <filesystem>
#include <map>
#include <sstream>
#include <string>
#include <unistd.h>
#include <vector>

namespace {

using namespace blobvk;

std::string attribute(xmlNode* node, const char* name) {
  xmlChar* v = xmlGetProp(node, reinterpret_cast<const xmlChar*>(name));
  std::string s = v ? reinterpret_cast<const char*>(v) : "";
  xmlFree(v);
  return s;
}

xmlNode* child(xmlNode* node, const char* name) {
  for (xmlNode* c = node ? node->children : nullptr; c; c = c->next)
    if (c->type == XML_ELEMENT_NODE && std::string(reinterpret_cast<const char*>(c->name)) == name) return c;
  return nullptr;
}

std::vector<double> numbers(xmlNode* array) {
  xmlChar* text = xmlNodeGetContent(array);
  std::istringstream in(reinterpret_cast<const char*>(text));
  xmlFree(text);
  std::vector<double> out;
  for (double v; in >> v;) out.push_back(v);
  return out;
}

// DataArrays of a section by Name ("" for the unnamed Points array).
std::map<std::string, xmlNode*> arrays(xmlNode* section) {
  std::map<std::string, xmlNode*> out;
  for (xmlNode* c = section ? section->children : nullptr; c; c = c->next)
    if (c->type == XML_ELEMENT_NODE) out[attribute(c, "Name")] = c;
  return out;
}

TEST(VtuWriter, TheFileParsesAsAnUnstructuredGridOfTheCutBody) {
  // A body cut in two by a blade sweeping through it under gravity, held at its bottom.
  fem::SimulationSettings settings;
  settings.materials[0].youngModulus = 1e4;
  settings.fixed = [](const mesh::Double3& p) { return p.y < -0.49; };
  surgery::SoftBody body(blobvk::testing::voxelBox(0.5, 0.1), settings);
  for (int k = 0; k <= 12; ++k) {
    surgery::StepInput in;
    const double z = -0.8 + 1.6 * k / 12;
    in.blade.push_back({{0.03, -1, z}, {0.03, 1, z}});
    in.endStroke = k == 12;
    body.step(in);
  }
  ASSERT_EQ(body.parts().size(), 2u);
  const mesh::TetMesh& m = body.mesh();

  const auto file = std::filesystem::temp_directory_path() / ("blobvk_vtu_" + std::to_string(getpid()) + ".vtu");
  surgery::writeVtu(file.string(), m, body.parts());
  xmlDoc* doc = xmlReadFile(file.string().c_str(), nullptr, XML_PARSE_NONET);
  ASSERT_NE(doc, nullptr) << "libxml2 cannot parse " << file;
  xmlNode* root = xmlDocGetRootElement(doc);
  EXPECT_STREQ(reinterpret_cast<const char*>(root->name), "VTKFile");
  EXPECT_EQ(attribute(root, "type"), "UnstructuredGrid");
  xmlNode* piece = child(child(root, "UnstructuredGrid"), "Piece");
  ASSERT_NE(piece, nullptr);
  const std::size_t points = std::stoul(attribute(piece, "NumberOfPoints")), cells = std::stoul(attribute(piece, "NumberOfCells"));
  EXPECT_EQ(points, m.nodeCount());
  EXPECT_EQ(cells, m.tetCount());

  auto cellArrays = arrays(child(piece, "Cells"));
  const std::vector<double> connectivity = numbers(cellArrays["connectivity"]), offsets = numbers(cellArrays["offsets"]),
                            types = numbers(cellArrays["types"]);
  ASSERT_EQ(connectivity.size(), 4 * cells);
  ASSERT_EQ(offsets.size(), cells);
  ASSERT_EQ(types.size(), cells);
  for (std::size_t t = 0; t < cells; ++t) {
    EXPECT_EQ(offsets[t], double(4 * (t + 1)));
    EXPECT_EQ(types[t], 10.0);  // VTK_TETRA
    for (int k = 0; k < 4; ++k) {
      ASSERT_LT(connectivity[4 * t + std::size_t(k)], double(points));
      ASSERT_EQ(connectivity[4 * t + std::size_t(k)], double(m.tets[t][std::size_t(k)]));
    }
  }
  const std::vector<double> xyz = numbers(arrays(child(piece, "Points"))[""]);
  auto pointArrays = arrays(child(piece, "PointData"));
  const std::vector<double> displacement = numbers(pointArrays["displacement"]);
  EXPECT_EQ(attribute(pointArrays["displacement"], "NumberOfComponents"), "3");
  ASSERT_EQ(xyz.size(), 3 * points);
  ASSERT_EQ(displacement.size(), 3 * points);
  double moved = 0;
  for (std::size_t i = 0; i < points; ++i) {
    // Shortest round-trip text: the values read back exactly.
    ASSERT_EQ(xyz[3 * i + 1], m.positions[i].y);
    ASSERT_EQ(displacement[3 * i + 1], m.positions[i].y - m.restPositions[i].y);
    moved = std::max(moved, std::abs(displacement[3 * i + 1]));
  }
  EXPECT_GT(moved, 1e-4);  // gravity moved the body: the displacements are not all zero
  auto dataArrays = arrays(child(piece, "CellData"));
  const std::vector<double> region = numbers(dataArrays["region"]), part = numbers(dataArrays["part"]);
  ASSERT_EQ(region.size(), cells);
  ASSERT_EQ(part.size(), cells);
  std::vector<std::size_t> perPart(2, 0);
  for (std::size_t t = 0; t < cells; ++t) {
    ASSERT_TRUE(part[t] == 0 || part[t] == 1) << part[t];
    ++perPart[std::size_t(part[t])];
  }
  EXPECT_EQ(perPart[0], body.parts()[0].size());
  EXPECT_EQ(perPart[1], body.parts()[1].size());
  xmlFreeDoc(doc);
  std::filesystem::remove(file);
}

TEST(VtuWriter, AnUnwritablePathIsReportedWithItsName) {
  const mesh::TetMesh box = blobvk::testing::voxelBox(0.2, 0.1);
  try {
    surgery::writeVtu("/nonexistent-dir/x.vtu", box, {});
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent-dir/x.vtu"), std::string::npos);
  }
}

}  // namespace
