// The tet mesh as a VTK XML UnstructuredGrid (.vtu, ASCII), readable by ParaView: current node
// positions, per-node displacement from rest, per-tet material region and part. One file per
// frame, beside the surface PLY (`blobvk cut --vtu`).
#pragma once

#include "blobvk/mesh/tetmesh.h"

#include <cstdint>
#include <ostream>
#include <string>
#include <vector>

namespace blobvk::surgery {

// Writes every node (nodes without a tet included, so indices match the mesh) and every tet as
// VTK_TETRA (type 10). `parts` are tet lists (SoftBody::parts()); a tet in none gets part
// 0xffffffff. Point data: "displacement" (Float64 x3); cell data: "region", "part" (UInt32).
// Numbers are written in the shortest form that reads back exactly (std::to_chars).
void writeVtu(std::ostream& out, const mesh::TetMesh& mesh, const std::vector<std::vector<std::uint32_t>>& parts);
// The same into a file; throws std::runtime_error naming the file when it cannot be written.
void writeVtu(const std::string& path, const mesh::TetMesh& mesh, const std::vector<std::vector<std::uint32_t>>& parts);

}  // namespace blobvk::surgery
