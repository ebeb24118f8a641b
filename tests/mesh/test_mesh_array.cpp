// MeshArray: resize(n) leaves plain-data elements unwritten (the arrays are written in full after
// they have their size), everything else behaves as std::vector.
#include "blobvk/mesh/trimesh.h"

#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <string>

using namespace blobvk;

TEST(MeshArray, ResizeWithinCapacityWritesNothing) {
  mesh::MeshArray<mesh::Float3> v(1000, mesh::Float3{1.5f, -2.0f, 3.0f});
  const mesh::Float3* data = v.data();
  v.clear();
  v.resize(1000);
  ASSERT_EQ(v.data(), data);  // the same storage: clear keeps the capacity
  // What the elements held before clear is still there: a std::vector would have written zeros.
  for (const mesh::Float3& p : v) ASSERT_EQ(p, (mesh::Float3{1.5f, -2.0f, 3.0f}));

  mesh::MeshArray<std::array<std::uint32_t, 3>> t(10, {7, 8, 9});
  t.resize(4);
  t.resize(10);
  EXPECT_EQ(t[9], (std::array<std::uint32_t, 3>{7, 8, 9}));
}

TEST(MeshArray, ValuesGivenAreWritten) {
  mesh::MeshArray<std::uint64_t> keys(4, 42);
  keys.resize(8, 0);
  EXPECT_EQ(keys, (mesh::MeshArray<std::uint64_t>{42, 42, 42, 42, 0, 0, 0, 0}));
  keys.assign(3, 5);
  EXPECT_EQ(keys, (mesh::MeshArray<std::uint64_t>{5, 5, 5}));
  mesh::MeshArray<mesh::Float3> p;
  p.push_back({1, 2, 3});
  p.emplace_back();  // construct(p) with no value: unwritten, like resize
  p.back() = {4, 5, 6};
  EXPECT_EQ(p[0], (mesh::Float3{1, 2, 3}));
  EXPECT_EQ(p[1], (mesh::Float3{4, 5, 6}));
}

TEST(MeshArray, OtherElementTypesAreConstructed) {
  mesh::MeshArray<std::string> names(3);
  for (const std::string& n : names) EXPECT_TRUE(n.empty());
  names.resize(5);
  EXPECT_TRUE(names[4].empty());
}
