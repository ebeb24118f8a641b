// glTF 2.0 / GLB writer over tinygltf (Debian's libtinygltf: the implementation is in the
// shared library, so this file includes the declarations only).
#include "blobvk/mesh/engine/gltf.h"

#include "blobvk/mesh/io_detail.h"

#include <tiny_gltf.h>

#include <algorithm>
#include <cstring>
#include <limits>
#include <span>
#include <sstream>
#include <stdexcept>

namespace blobvk::mesh {

namespace {

constexpr int kArrayBuffer = 34962;         // GL_ARRAY_BUFFER
constexpr int kElementArrayBuffer = 34963;  // GL_ELEMENT_ARRAY_BUFFER

// Appends `bytes` to the one buffer and gives it a view; returns the view's index. Every block
// is a multiple of 4 bytes (floats, uint32), so views stay 4-byte aligned without padding.
int addView(tinygltf::Model& model, const void* bytes, std::size_t size, int target) {
  std::vector<unsigned char>& data = model.buffers[0].data;
  tinygltf::BufferView view;
  view.buffer = 0;
  view.byteOffset = data.size();
  view.byteLength = size;
  view.target = target;
  data.insert(data.end(), static_cast<const unsigned char*>(bytes), static_cast<const unsigned char*>(bytes) + size);
  model.bufferViews.push_back(view);
  return int(model.bufferViews.size() - 1);
}

int addVec3Accessor(tinygltf::Model& model, std::span<const Float3> values, bool withBounds) {
  tinygltf::Accessor a;
  a.bufferView = addView(model, values.data(), values.size() * sizeof(Float3), kArrayBuffer);
  a.componentType = TINYGLTF_COMPONENT_TYPE_FLOAT;
  a.type = TINYGLTF_TYPE_VEC3;
  a.count = values.size();
  if (withBounds) {  // glTF requires min/max on POSITION
    Float3 lo{std::numeric_limits<float>::max(), std::numeric_limits<float>::max(), std::numeric_limits<float>::max()};
    Float3 hi{-lo.x, -lo.y, -lo.z};
    for (const Float3& p : values) {
      lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
      hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
    }
    a.minValues = {lo.x, lo.y, lo.z};
    a.maxValues = {hi.x, hi.y, hi.z};
  }
  model.accessors.push_back(a);
  return int(model.accessors.size() - 1);
}

tinygltf::Model buildModel(const TriMesh& mesh) {
  tinygltf::Model model;
  model.asset.version = "2.0";
  model.asset.generator = "blobvk";
  model.scenes.emplace_back();
  model.scenes[0].name = "blobvk";  // also keeps an empty scene a JSON object, not null
  model.defaultScene = 0;
  // glTF accessors need count >= 1: a mesh without triangles is an empty scene.
  if (mesh.triangles.empty()) return model;

  model.buffers.emplace_back();
  tinygltf::Primitive prim;
  prim.mode = TINYGLTF_MODE_TRIANGLES;
  prim.attributes["POSITION"] = addVec3Accessor(model, mesh.positions, true);
  if (!mesh.normals.empty()) prim.attributes["NORMAL"] = addVec3Accessor(model, mesh.normals, false);
  if (!mesh.colours.empty()) prim.attributes["COLOR_0"] = addVec3Accessor(model, mesh.colours, false);

  tinygltf::Accessor indices;
  indices.bufferView = addView(model, mesh.triangles.data(), mesh.triangles.size() * sizeof(mesh.triangles[0]),
                               kElementArrayBuffer);
  indices.componentType = TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT;
  indices.type = TINYGLTF_TYPE_SCALAR;
  indices.count = mesh.triangles.size() * 3;
  model.accessors.push_back(indices);
  prim.indices = int(model.accessors.size() - 1);

  // glTF's default material is fully metallic, which engines render nearly black without an
  // environment map; a rough dielectric shows the vertex colours as they are.
  tinygltf::Material material;
  material.name = "blobvk";
  material.pbrMetallicRoughness.metallicFactor = 0.0;
  material.pbrMetallicRoughness.roughnessFactor = 0.6;
  model.materials.push_back(material);
  prim.material = 0;

  tinygltf::Mesh gltfMesh;
  gltfMesh.name = "blobvk";
  gltfMesh.primitives.push_back(prim);
  model.meshes.push_back(gltfMesh);
  tinygltf::Node node;
  node.mesh = 0;
  model.nodes.push_back(node);
  model.scenes[0].nodes.push_back(0);
  return model;
}

}  // namespace

std::string encodeGltf(const TriMesh& mesh, bool binary) {
  detail::validateForWrite(mesh, binary ? "writeGlb" : "writeGltf");
  const tinygltf::Model model = buildModel(mesh);
  std::ostringstream out;
  tinygltf::TinyGLTF writer;
  if (!writer.WriteGltfSceneToStream(&model, out, /*prettyPrint=*/!binary, binary))
    throw std::runtime_error(std::string(binary ? "GLB" : "glTF") + " encoder: tinygltf failed to write the model");
  return std::move(out).str();
}

bool isGltfExtension(const std::string& extension) {
  std::string e = extension;
  std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return e == ".gltf" || e == ".glb";
}

void writeGltf(const TriMesh& mesh, const std::string& path) {
  const std::string ext = detail::lowerExtension(path);
  if (!isGltfExtension(ext)) throw std::invalid_argument(path + ": not a glTF file name (.gltf or .glb)");
  detail::writeFileBytes(path, encodeGltf(mesh, ext == ".glb"));
}

}  // namespace blobvk::mesh
