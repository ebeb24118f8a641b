// Byte-for-byte comparison of two meshes (positions, normals, colours, edge keys, triangles), for
// tests whose oracle is a second run that must give the same bytes (an incremental update against
// a full polygonization).
#pragma once

#include "blobvk/mesh/trimesh.h"

#include <gtest/gtest.h>

#include <cstring>
#include <string>
#include <vector>

namespace blobvk::testing {

inline void expectSameMeshBytes(const mesh::TriMesh& got, const mesh::TriMesh& want, const std::string& what) {
  auto same = [](const auto& a, const auto& b) {
    return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(a[0])) == 0);
  };
  ASSERT_EQ(got.vertexCount(), want.vertexCount()) << what;
  ASSERT_EQ(got.triangleCount(), want.triangleCount()) << what;
  EXPECT_TRUE(same(got.positions, want.positions)) << what << ": positions";
  EXPECT_TRUE(same(got.normals, want.normals)) << what << ": normals";
  EXPECT_TRUE(same(got.colours, want.colours)) << what << ": colours";
  EXPECT_TRUE(same(got.edgeKeys, want.edgeKeys)) << what << ": edge keys";
  EXPECT_TRUE(same(got.triangles, want.triangles)) << what << ": triangles";
}

}  // namespace blobvk::testing
