// glTF 2.0 output of a TriMesh through tinygltf: one mesh of one triangle primitive with
// POSITION (with the min/max glTF requires), NORMAL and COLOR_0 (float RGB) when the mesh has
// them, and 32-bit indices; a non-metallic default material so engines do not show the model as
// bare metal. Buffers are embedded (base64 in .gltf, the BIN chunk in .glb), so one file is the
// whole asset. The bytes are deterministic (tinygltf writes keys sorted).
#pragma once

#include "blobvk/mesh/trimesh.h"

#include <string>

namespace blobvk::mesh {

// The bytes of a .glb (binary = true) or a .gltf (JSON with the buffer as a data URI).
std::string encodeGltf(const TriMesh& mesh, bool binary);
// By extension: .glb or .gltf (case-insensitive); std::invalid_argument for any other.
void writeGltf(const TriMesh& mesh, const std::string& path);
// True for the extensions writeGltf takes (".gltf", ".glb", any case; with the dot).
bool isGltfExtension(const std::string& extension);

}  // namespace blobvk::mesh
