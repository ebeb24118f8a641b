#include "cube_mesh.h"

#include "blobvk/mesh/checks.h"
#include "blobvk/mesh/io.h"

#include <span>
#include <gtest/gtest.h>

#include <bit>
#include <cstdint>

#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <stdexcept>
#include <unistd.h>

namespace blobvk {
namespace {

namespace fs = std::filesystem;

class MeshIo : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           ("blobvk_mesh_io_" + std::to_string(::getpid()) + "_" + info->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }
  std::string write(const std::string& name, const std::string& bytes) const {
    std::ofstream(path(name), std::ios::binary) << bytes;
    return path(name);
  }
  static std::string read(const std::string& p) {
    std::ifstream in(p, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
  }
  fs::path dir_;
};

// A cube with normals and colours that are exact multiples of 1/255 (PLY stores uchar colours).
mesh::TriMesh attributedCube() {
  mesh::TriMesh m = testing::unitCube();
  for (std::size_t i = 0; i < m.positions.size(); ++i) {
    const auto& p = m.positions[i];
    m.normals.push_back({p.x - 0.5f, p.y - 0.5f, 0.1f * float(i) - 0.3f});
    m.colours.push_back({float(i * 30) / 255.0f, float(255 - i) / 255.0f, float(i % 3 * 100) / 255.0f});
  }
  m.positions[3].x = 0.1f;  // a value with no short decimal form: ascii must round-trip it
  return m;
}

void expectNear(std::span<const mesh::Float3> a, std::span<const mesh::Float3> b, float tol) {
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_NEAR(a[i].x, b[i].x, tol) << i;
    EXPECT_NEAR(a[i].y, b[i].y, tol) << i;
    EXPECT_NEAR(a[i].z, b[i].z, tol) << i;
  }
}

TEST_F(MeshIo, PlyBinaryRoundTrip) {
  const mesh::TriMesh m = attributedCube();
  mesh::writePly(m, path("a.ply"), true);
  const mesh::TriMesh r = mesh::readPly(path("a.ply"));
  EXPECT_EQ(r.positions, m.positions);
  EXPECT_EQ(r.normals, m.normals);
  expectNear(r.colours, m.colours, 1e-6f);
  EXPECT_EQ(r.triangles, m.triangles);
}

TEST_F(MeshIo, PlyAsciiRoundTripIsExact) {
  const mesh::TriMesh m = attributedCube();
  mesh::writePly(m, path("a.ply"), false);
  const mesh::TriMesh r = mesh::readPly(path("a.ply"));
  EXPECT_EQ(r.positions, m.positions);
  EXPECT_EQ(r.normals, m.normals);
  expectNear(r.colours, m.colours, 1e-6f);
  EXPECT_EQ(r.triangles, m.triangles);
}

TEST_F(MeshIo, ObjRoundTripKeepsNormalsAndColours) {
  const mesh::TriMesh m = attributedCube();
  mesh::writeObj(m, path("a.obj"));
  const mesh::TriMesh r = mesh::readObj(path("a.obj"));
  EXPECT_EQ(r.positions, m.positions);
  EXPECT_EQ(r.normals, m.normals);
  EXPECT_EQ(r.colours, m.colours);
  EXPECT_EQ(r.triangles, m.triangles);
}

TEST_F(MeshIo, StlRoundTripWeldsBackToTheSameTopology) {
  const mesh::TriMesh m = testing::unitCube();
  mesh::writeStl(m, path("a.stl"));
  EXPECT_EQ(fs::file_size(path("a.stl")), 84u + 50u * 12u);
  const mesh::TriMesh r = mesh::readStl(path("a.stl"));
  ASSERT_EQ(r.triangles.size(), m.triangles.size());
  EXPECT_EQ(r.positions.size(), 8u);
  for (std::size_t t = 0; t < m.triangles.size(); ++t)
    for (int k = 0; k < 3; ++k)
      EXPECT_EQ(r.positions[r.triangles[t][std::size_t(k)]], m.positions[m.triangles[t][std::size_t(k)]]);
  const mesh::MeshReport report = mesh::checkMesh(r);
  EXPECT_TRUE(report.watertight());
  EXPECT_NEAR(report.volume, 1.0, 1e-9);
}

TEST_F(MeshIo, AsciiStlIsRead) {
  const std::string p = write("a.stl",
                              "solid t\nfacet normal 0 0 1\n outer loop\n  vertex 0 0 0\n  vertex 1 0 0\n"
                              "  vertex 0 1 0\n endloop\nendfacet\nendsolid t\n");
  const mesh::TriMesh r = mesh::readStl(p);
  ASSERT_EQ(r.triangles.size(), 1u);
  EXPECT_EQ(r.positions[1], (mesh::Float3{1, 0, 0}));
}

TEST_F(MeshIo, WritersAreByteDeterministic) {
  const mesh::TriMesh m = attributedCube();
  for (const char* name : {"a.ply", "a.obj", "a.stl"}) {
    mesh::writeMesh(m, path(std::string("1") + name));
    mesh::writeMesh(m, path(std::string("2") + name));
    EXPECT_EQ(read(path(std::string("1") + name)), read(path(std::string("2") + name))) << name;
  }
  mesh::writePly(m, path("x.ply"), false);
  EXPECT_NE(read(path("x.ply")).find("0.1 "), std::string::npos);
}

// ---- writers and readers against hand-written files -------------------------------------------
// The round trips above would pass if a writer and its reader agreed on a wrong layout; these
// pin each writer's bytes to the format as written out by hand here, and read hand-made files.

// One triangle in the plane z = -2 with face normal +z, distinct vertex normals, and colours that
// are exact in bytes: 0.2 * 255 = 51, 0.6 * 255 = 153, 0.4 * 255 = 102.
mesh::TriMesh handTriangle() {
  mesh::TriMesh m;
  m.positions = {{0, 0, -2}, {2, 0, -2}, {0, 0.5f, -2}};
  m.normals = {{0, 0, 1}, {0, 1, 0}, {1, 0, 0}};
  m.colours = {{1, 0, 0.2f}, {0, 0.6f, 1}, {0.4f, 0.4f, 0.4f}};
  m.triangles = {{0, 1, 2}};
  return m;
}

const char* const kHandPlyHeader =
    "comment written by blobvk\n"
    "element vertex 3\n"
    "property float x\nproperty float y\nproperty float z\n"
    "property float nx\nproperty float ny\nproperty float nz\n"
    "property uchar red\nproperty uchar green\nproperty uchar blue\n"
    "element face 1\n"
    "property list uchar int vertex_indices\n"
    "end_header\n";

// Little-endian bytes built arithmetically, whatever the host's byte order.
void appendLe32(std::string& out, std::uint32_t v) {
  for (int b = 0; b < 4; ++b) out += char((v >> (8 * b)) & 0xffu);
}
void appendLeFloat(std::string& out, float f) { appendLe32(out, std::bit_cast<std::uint32_t>(f)); }

TEST_F(MeshIo, AsciiPlyIsTheHandWrittenFile) {
  mesh::writePly(handTriangle(), path("t.ply"), false);
  const std::string expected = std::string("ply\nformat ascii 1.0\n") + kHandPlyHeader +
                               "0 0 -2 0 0 1 255 0 51\n"
                               "2 0 -2 0 1 0 0 153 255\n"
                               "0 0.5 -2 1 0 0 102 102 102\n"
                               "3 0 1 2\n";
  EXPECT_EQ(read(path("t.ply")), expected);
}

TEST_F(MeshIo, BinaryPlyIsTheHandWrittenLayout) {
  mesh::writePly(handTriangle(), path("t.ply"), true);
  std::string expected = std::string("ply\nformat binary_little_endian 1.0\n") + kHandPlyHeader;
  const float vertices[3][6] = {{0, 0, -2, 0, 0, 1}, {2, 0, -2, 0, 1, 0}, {0, 0.5f, -2, 1, 0, 0}};
  const unsigned char rgb[3][3] = {{255, 0, 51}, {0, 153, 255}, {102, 102, 102}};
  for (int v = 0; v < 3; ++v) {
    for (float f : vertices[v]) appendLeFloat(expected, f);
    for (unsigned char c : rgb[v]) expected += char(c);
  }
  expected += char(3);
  for (std::uint32_t i : {0u, 1u, 2u}) appendLe32(expected, i);
  EXPECT_EQ(read(path("t.ply")), expected);
}

TEST_F(MeshIo, ObjIsTheHandWrittenFile) {
  mesh::writeObj(handTriangle(), path("t.obj"));
  EXPECT_EQ(read(path("t.obj")),
            "# written by blobvk\n"
            "v 0 0 -2 1 0 0.2\n"
            "v 2 0 -2 0 0.6 1\n"
            "v 0 0.5 -2 0.4 0.4 0.4\n"
            "vn 0 0 1\nvn 0 1 0\nvn 1 0 0\n"
            "f 1//1 2//2 3//3\n");
}

TEST_F(MeshIo, BinaryStlIsTheHandWrittenLayout) {
  mesh::writeStl(handTriangle(), path("t.stl"));
  const std::string bytes = read(path("t.stl"));
  ASSERT_EQ(bytes.size(), 84u + 50u);
  EXPECT_NE(bytes.substr(0, 5), "solid");  // a binary header must not read as ascii STL
  std::string body;
  appendLe32(body, 1);  // triangle count
  // Facet normal (the unit cross product of the edges: +z), then the three corners.
  for (float f : {0.0f, 0.0f, 1.0f, 0.0f, 0.0f, -2.0f, 2.0f, 0.0f, -2.0f, 0.0f, 0.5f, -2.0f}) appendLeFloat(body, f);
  body += std::string(2, '\0');  // attribute byte count
  EXPECT_EQ(bytes.substr(80), body);
}

// A binary PLY as other tools write it: doubles, an extra vertex property, uint list indices,
// a quad, and an element the reader must skip.
TEST_F(MeshIo, HandMadeBinaryPlyWithOtherTypesIsRead) {
  std::string bytes =
      "ply\nformat binary_little_endian 1.0\nobj_info made by hand\n"
      "element vertex 4\nproperty double x\nproperty double y\nproperty double z\nproperty float confidence\n"
      "element face 1\nproperty list uchar uint vertex_indices\n"
      "element edge 1\nproperty int vertex1\nproperty int vertex2\nend_header\n";
  const double corners[4][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0.25}, {0, 1, 0}};
  for (const auto& c : corners) {
    for (double d : c) {
      const std::uint64_t u = std::bit_cast<std::uint64_t>(d);
      appendLe32(bytes, std::uint32_t(u));
      appendLe32(bytes, std::uint32_t(u >> 32));
    }
    appendLeFloat(bytes, 0.5f);
  }
  bytes += char(4);
  for (std::uint32_t i : {0u, 1u, 2u, 3u}) appendLe32(bytes, i);
  appendLe32(bytes, 0);
  appendLe32(bytes, 2);
  const mesh::TriMesh r = mesh::readPly(write("q.ply", bytes));
  ASSERT_EQ(r.positions.size(), 4u);
  EXPECT_EQ(r.positions[2], (mesh::Float3{1, 1, 0.25f}));
  EXPECT_TRUE(r.normals.empty());
  EXPECT_TRUE(r.colours.empty());
  // The quad becomes a fan from its first corner.
  ASSERT_EQ(r.triangles.size(), 2u);
  EXPECT_EQ(r.triangles[0], (std::array<std::uint32_t, 3>{0, 1, 2}));
  EXPECT_EQ(r.triangles[1], (std::array<std::uint32_t, 3>{0, 2, 3}));
}

TEST_F(MeshIo, HandMadeAsciiPlyWithFloatColoursIsRead) {
  const std::string p = write("c.ply",
                              "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                              "property float z\nproperty float nx\nproperty float ny\nproperty float nz\n"
                              "property float red\nproperty float green\nproperty float blue\n"
                              "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
                              "0 0 0 0 0 1 0.25 0.5 1\n1 0 0 0 0 1 0 0 0\n0 1 0 0 0 1 1 1 1\n3 2 1 0\n");
  const mesh::TriMesh r = mesh::readPly(p);
  ASSERT_EQ(r.normals.size(), 3u);
  EXPECT_EQ(r.normals[1], (mesh::Float3{0, 0, 1}));
  ASSERT_EQ(r.colours.size(), 3u);
  EXPECT_EQ(r.colours[0], (mesh::Float3{0.25f, 0.5f, 1}));  // float colours are not divided by 255
  EXPECT_EQ(r.triangles[0], (std::array<std::uint32_t, 3>{2, 1, 0}));
}

TEST_F(MeshIo, HandMadeObjWithNormalsAndColoursIsRead) {
  const std::string p = write("n.obj",
                              "# hand made\nv 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 0 1 0 0 0 1\n"
                              "vn 0 0 -1\nvn 0 0.6 0.8\nvn 1 0 0\nf 1//1 2//2 3//3\n");
  const mesh::TriMesh r = mesh::readObj(p);
  ASSERT_EQ(r.positions.size(), 3u);
  EXPECT_EQ(r.positions[2], (mesh::Float3{0, 1, 0}));
  ASSERT_EQ(r.colours.size(), 3u);
  EXPECT_EQ(r.colours[1], (mesh::Float3{0, 1, 0}));
  ASSERT_EQ(r.normals.size(), 3u);
  EXPECT_EQ(r.normals[1], (mesh::Float3{0, 0.6f, 0.8f}));
  EXPECT_EQ(r.triangles[0], (std::array<std::uint32_t, 3>{0, 1, 2}));
  // Corner normals that do not pair one to one with the vertices are not per-vertex normals.
  const mesh::TriMesh shared = mesh::readObj(write("s.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1\n"));
  EXPECT_TRUE(shared.normals.empty());
}

TEST_F(MeshIo, WriteMeshRejectsUnknownExtensions) {
  try {
    mesh::writeMesh(testing::unitCube(), path("a.xyz"));
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(".xyz"), std::string::npos) << e.what();
  }
  EXPECT_THROW(mesh::writeMesh(testing::unitCube(), path("noextension")), std::invalid_argument);
}

TEST_F(MeshIo, WritersRejectInconsistentMeshes) {
  mesh::TriMesh m = testing::unitCube();
  m.normals.resize(3);
  EXPECT_THROW(mesh::writePly(m, path("a.ply")), std::invalid_argument);
  m = testing::unitCube();
  m.triangles.push_back({0, 1, 8});
  EXPECT_THROW(mesh::writeObj(m, path("a.obj")), std::invalid_argument);
}

TEST_F(MeshIo, UnwritableAndMissingPathsNameTheFile) {
  const std::string missing = path("does/not/exist.ply");
  try {
    mesh::readPly(missing);
    FAIL();
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(missing), std::string::npos);
  }
  EXPECT_THROW(mesh::writePly(testing::unitCube(), missing), std::runtime_error);
}

struct BadFile {
  const char* name;
  std::string bytes;
  const char* expected;  // a piece of the message
};

void expectRejected(const std::string& p, const char* expected, bool ply) {
  try {
    if (ply) mesh::readPly(p);
    else mesh::readObj(p);
    ADD_FAILURE() << p << " was accepted";
  } catch (const std::runtime_error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(p), std::string::npos) << what;
    EXPECT_NE(what.find(expected), std::string::npos) << "message: " << what;
  }
}

const std::string kPlyHead = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                             "element face 1\nproperty list uchar int vertex_indices\nend_header\n";

TEST_F(MeshIo, MalformedPlyIsRejectedWithAMessage) {
  std::string bin = "ply\nformat binary_little_endian 1.0\nelement vertex 1000000000\nproperty float x\n"
                    "property float y\nproperty float z\nend_header\n";
  bin += std::string(24, '\0');
  const std::vector<BadFile> bad = {
      {"empty.ply", "", "not a PLY file"},
      {"notply.ply", "hello\n", "not a PLY file"},
      {"noend.ply", "ply\nformat ascii 1.0\nelement vertex 1\n", "end_header"},
      {"bigendian.ply", "ply\nformat binary_big_endian 1.0\nend_header\n", "unsupported format"},
      {"nofmt.ply", "ply\nelement vertex 0\nproperty float x\nend_header\n", "no format"},
      {"badtype.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty quad x\nend_header\n", "unknown property type"},
      {"noxyz.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n1\n", "lacks x, y or z"},
      {"negcount.ply", "ply\nformat ascii 1.0\nelement vertex -5\nend_header\n", "malformed element"},
      {"hugecount.ply", bin, "declares 1000000000 entries"},
      {"shortdata.ply", kPlyHead + "0 0 0\n1 0 0\n", "declares 3 entries"},
      {"shortface.ply", kPlyHead + "0 0 0\n1 0 0\n0 1 0\n3 0 1\n", "unexpected end"},
      {"nan.ply", kPlyHead + "0 0 zero\n1 0 0\n0 1 0\n3 0 1 2\n", "not a number"},
      {"badindex.ply", kPlyHead + "0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n", "uses vertex 7"},
      {"negindex.ply", kPlyHead + "0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n", "invalid vertex index"},
      {"twovertex.ply", kPlyHead + "0 0 0\n1 0 0\n0 1 0\n2 0 1\n", "fewer than 3"},
      {"fraction.ply", kPlyHead + "0 0 0\n1 0 0\n0 1 0\n3 0 1.5 2\n", "not an integer"},
      {"huge.ply", kPlyHead + "0 0 1e300\n1 0 0\n0 1 0\n3 0 1 2\n", "outside the float range"},
  };
  for (const BadFile& b : bad) expectRejected(write(b.name, b.bytes), b.expected, true);
}

TEST_F(MeshIo, MalformedObjIsRejectedWithAMessage) {
  const std::vector<BadFile> bad = {
      {"shortv.obj", "v 1 2\n", "3 coordinates"},
      {"nanv.obj", "v 1 2 x\n", "not a number"},
      {"faceidx.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", "does not name"},
      {"facezero.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", "does not name"},
      {"facetwo.obj", "v 0 0 0\nv 1 0 0\nf 1 2\n", "at least 3"},
      {"badnormal.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1//1 2//1 3//1\n", "normal index"},
      {"mixedcolour.obj", "v 0 0 0 1 0 0\nv 1 0 0\n", "colour"},
  };
  for (const BadFile& b : bad) expectRejected(write(b.name, b.bytes), b.expected, false);
}

TEST_F(MeshIo, ObjAcceptsRelativeIndicesAndPolygons) {
  const std::string p = write("q.obj", "# quad\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nf -4/1 -3/1 -2/1 -1/1\n");
  const mesh::TriMesh r = mesh::readObj(p);
  ASSERT_EQ(r.triangles.size(), 2u);
  EXPECT_EQ(r.triangles[1], (std::array<std::uint32_t, 3>{0, 2, 3}));
  EXPECT_TRUE(r.normals.empty());
}

// Mutated valid files must either load or throw std::runtime_error: never crash or hang.
TEST_F(MeshIo, FuzzedFilesNeverCrash) {
  const mesh::TriMesh m = attributedCube();
  mesh::writePly(m, path("b.ply"), true);
  mesh::writePly(m, path("a.ply"), false);
  mesh::writeObj(m, path("o.obj"));
  mesh::writeStl(m, path("s.stl"));
  std::mt19937 rng(4242);
  int loaded = 0, rejected = 0;
  for (const char* name : {"b.ply", "a.ply", "o.obj", "s.stl"}) {
    const std::string original = read(path(name));
    const std::string ext = fs::path(name).extension().string();
    for (int trial = 0; trial < 400; ++trial) {
      std::string bytes = original;
      if (trial % 4 == 0) {
        bytes.resize(std::size_t(rng() % (bytes.size() + 1)));  // truncation
      } else {
        const int flips = 1 + int(rng() % 8);
        for (int f = 0; f < flips; ++f) bytes[rng() % bytes.size()] = char(rng() % 256);
      }
      const std::string p = write(std::string("fuzz") + ext, bytes);
      try {
        const mesh::TriMesh r = mesh::readMesh(p);
        for (const auto& t : r.triangles)
          for (auto v : t) ASSERT_LT(v, r.positions.size());
        ++loaded;
      } catch (const std::runtime_error&) {
        ++rejected;
      }
    }
  }
  EXPECT_GT(rejected, 0);
  EXPECT_GT(loaded, 0);
}

}  // namespace
}  // namespace blobvk
