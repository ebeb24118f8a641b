// glTF / GLB export read back with tinygltf's loader: the asset validates as glTF 2.0, and every
// accessor holds exactly the mesh's data (counts, types, POSITION min/max, bytes, indices).
#include "blobvk/mesh/engine/gltf.h"
#include "shipped_mesh.h"

#include <span>
#include <gtest/gtest.h>
#include <tiny_gltf.h>

#include <cstring>
#include <filesystem>

#include <unistd.h>

namespace {

using blobvk::mesh::Float3;
using blobvk::mesh::TriMesh;

tinygltf::Model load(const std::string& bytes, bool binary) {
  tinygltf::Model model;
  tinygltf::TinyGLTF loader;
  std::string err, warn;
  const bool ok = binary ? loader.LoadBinaryFromMemory(&model, &err, &warn, reinterpret_cast<const unsigned char*>(bytes.data()),
                                                      unsigned(bytes.size()))
                         : loader.LoadASCIIFromString(&model, &err, &warn, bytes.data(), unsigned(bytes.size()), "");
  EXPECT_TRUE(ok) << err;
  EXPECT_TRUE(warn.empty()) << warn;
  return model;
}

// The accessor's elements as bytes, via its view (tinygltf has resolved the buffer).
std::vector<unsigned char> accessorBytes(const tinygltf::Model& model, int accessor, std::size_t elementSize) {
  const tinygltf::Accessor& a = model.accessors.at(std::size_t(accessor));
  const tinygltf::BufferView& v = model.bufferViews.at(std::size_t(a.bufferView));
  const auto& data = model.buffers.at(std::size_t(v.buffer)).data;
  const std::size_t begin = v.byteOffset + a.byteOffset, size = a.count * elementSize;
  EXPECT_LE(begin + size, data.size());
  EXPECT_EQ(v.byteStride, 0u);  // tightly packed
  return {data.begin() + std::ptrdiff_t(begin), data.begin() + std::ptrdiff_t(begin + size)};
}

void expectVec3(const tinygltf::Model& model, const tinygltf::Primitive& p, const char* name, std::span<const Float3> values) {
  ASSERT_TRUE(p.attributes.count(name)) << name;
  const int index = p.attributes.at(name);
  const tinygltf::Accessor& a = model.accessors.at(std::size_t(index));
  EXPECT_EQ(a.componentType, TINYGLTF_COMPONENT_TYPE_FLOAT) << name;
  EXPECT_EQ(a.type, TINYGLTF_TYPE_VEC3) << name;
  EXPECT_EQ(a.count, values.size()) << name;
  const auto bytes = accessorBytes(model, index, sizeof(Float3));
  ASSERT_EQ(bytes.size(), values.size() * sizeof(Float3));
  EXPECT_EQ(std::memcmp(bytes.data(), values.data(), bytes.size()), 0) << name << " differs from the mesh";
}

void expectSameMesh(const tinygltf::Model& model, const TriMesh& mesh) {
  ASSERT_EQ(model.meshes.size(), 1u);
  ASSERT_EQ(model.meshes[0].primitives.size(), 1u);
  ASSERT_EQ(model.scenes.size(), 1u);
  ASSERT_EQ(model.nodes.size(), 1u);
  EXPECT_EQ(model.nodes[0].mesh, 0);
  EXPECT_EQ(model.asset.version, "2.0");
  const tinygltf::Primitive& p = model.meshes[0].primitives[0];
  EXPECT_EQ(p.mode, TINYGLTF_MODE_TRIANGLES);
  expectVec3(model, p, "POSITION", mesh.positions);
  expectVec3(model, p, "NORMAL", mesh.normals);
  expectVec3(model, p, "COLOR_0", mesh.colours);

  // POSITION's min/max are the bounds of the positions, computed here independently.
  const tinygltf::Accessor& pos = model.accessors.at(std::size_t(p.attributes.at("POSITION")));
  ASSERT_EQ(pos.minValues.size(), 3u);
  ASSERT_EQ(pos.maxValues.size(), 3u);
  for (int axis = 0; axis < 3; ++axis) {
    float lo = 1e30f, hi = -1e30f;
    for (const Float3& q : mesh.positions) {
      const float c = axis == 0 ? q.x : axis == 1 ? q.y : q.z;
      lo = std::min(lo, c), hi = std::max(hi, c);
    }
    EXPECT_EQ(float(pos.minValues[std::size_t(axis)]), lo) << "axis " << axis;
    EXPECT_EQ(float(pos.maxValues[std::size_t(axis)]), hi) << "axis " << axis;
  }

  const tinygltf::Accessor& idx = model.accessors.at(std::size_t(p.indices));
  EXPECT_EQ(idx.componentType, TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT);
  EXPECT_EQ(idx.type, TINYGLTF_TYPE_SCALAR);
  EXPECT_EQ(idx.count, mesh.triangles.size() * 3);
  const auto bytes = accessorBytes(model, p.indices, 4);
  ASSERT_EQ(bytes.size(), mesh.triangles.size() * 12);
  EXPECT_EQ(std::memcmp(bytes.data(), mesh.triangles.data(), bytes.size()), 0) << "indices differ";

  // Not the glTF default (fully metallic): engines would render the model almost black.
  ASSERT_EQ(model.materials.size(), 1u);
  EXPECT_EQ(p.material, 0);
  EXPECT_EQ(model.materials[0].pbrMetallicRoughness.metallicFactor, 0.0);
}

TEST(Gltf, GlbRoundTripsAShippedMesh) {
  const TriMesh mesh = shippedMesh("dice", 32);
  ASSERT_FALSE(mesh.normals.empty());
  ASSERT_FALSE(mesh.colours.empty());
  const std::string glb = blobvk::mesh::encodeGltf(mesh, true);
  ASSERT_GE(glb.size(), 12u);
  EXPECT_EQ(glb.substr(0, 4), "glTF");
  expectSameMesh(load(glb, true), mesh);
  EXPECT_EQ(blobvk::mesh::encodeGltf(mesh, true), glb) << "the encoding is deterministic";
}

TEST(Gltf, GltfTextRoundTripsWithTheBufferEmbedded) {
  const TriMesh mesh = shippedMesh("twisted_column", 24);
  const std::string text = blobvk::mesh::encodeGltf(mesh, false);
  EXPECT_NE(text.find("data:application/octet-stream;base64,"), std::string::npos);
  expectSameMesh(load(text, false), mesh);
}

TEST(Gltf, AttributesAreOptional) {
  TriMesh mesh = shippedMesh("eggshell", 16);
  mesh.normals.clear();
  mesh.colours.clear();
  const tinygltf::Model model = load(blobvk::mesh::encodeGltf(mesh, true), true);
  ASSERT_EQ(model.meshes.size(), 1u);
  const auto& attributes = model.meshes[0].primitives[0].attributes;
  EXPECT_EQ(attributes.size(), 1u);
  EXPECT_TRUE(attributes.count("POSITION"));
}

TEST(Gltf, AMeshWithoutTrianglesIsAnEmptyScene) {
  const tinygltf::Model model = load(blobvk::mesh::encodeGltf(TriMesh{}, true), true);
  EXPECT_TRUE(model.meshes.empty());
  EXPECT_TRUE(model.accessors.empty());
  EXPECT_EQ(model.scenes.size(), 1u);
}

TEST(Gltf, BadInputIsRefusedWithAReason) {
  TriMesh mesh;
  mesh.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  mesh.triangles = {{0, 1, 3}};
  EXPECT_THROW(blobvk::mesh::encodeGltf(mesh, true), std::invalid_argument);
  mesh.triangles = {{0, 1, 2}};
  mesh.normals = {{0, 0, 1}};
  EXPECT_THROW(blobvk::mesh::encodeGltf(mesh, false), std::invalid_argument);
  EXPECT_THROW(blobvk::mesh::writeGltf(mesh, "model.obj"), std::invalid_argument);
}

TEST(Gltf, WriteGltfPicksTheContainerByExtension) {
  const TriMesh mesh = shippedMesh("dice", 16);
  const auto dir = std::filesystem::temp_directory_path() / ("blobvk_gltf_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  blobvk::mesh::writeGltf(mesh, (dir / "a.GLB").string());
  blobvk::mesh::writeGltf(mesh, (dir / "a.gltf").string());
  tinygltf::TinyGLTF loader;
  tinygltf::Model binary, text;
  std::string err, warn;
  EXPECT_TRUE(loader.LoadBinaryFromFile(&binary, &err, &warn, (dir / "a.GLB").string())) << err;
  EXPECT_TRUE(loader.LoadASCIIFromFile(&text, &err, &warn, (dir / "a.gltf").string())) << err;
  expectSameMesh(binary, mesh);
  expectSameMesh(text, mesh);
  std::filesystem::remove_all(dir);
}

}  // namespace
