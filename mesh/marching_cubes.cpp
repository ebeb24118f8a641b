// Generates the marching-cubes case table from the face rule (see marching_cubes.h), at compile
// time, so the table cannot drift from the rule and its size limit is checked by the compiler.
#include "blobvk/mesh/marching_cubes.h"

namespace blobvk::mesh {
namespace {

constexpr int cornerOf(int x, int y, int z) { return x | (y << 1) | (z << 2); }

// The edge joining two corners that differ in exactly one coordinate.
constexpr int edgeBetween(int c0, int c1) {
  const int diff = c0 ^ c1;
  const int axis = diff == 1 ? 0 : diff == 2 ? 1 : 2;
  const int x = c0 & 1, y = (c0 >> 1) & 1, z = (c0 >> 2) & 1;
  // The other two coordinates in increasing axis order (header: x -> (y, z), y -> (x, z), z -> (x, y)).
  const int u = axis == 0 ? y : x;
  const int v = axis == 2 ? y : z;
  return axis * 4 + u + 2 * v;
}

struct Face {
  std::array<int, 4> corners;  // counter-clockwise seen from outside the cube
};

// Face (axis a, side s): with u, v the next two axes cyclically, (0,0) (1,0) (1,1) (0,1) in (u, v)
// turns counter-clockwise around +a (u x v = a), which is the outward normal for s = 1; for s = 0
// the outward normal is -a, so the order is reversed.
constexpr std::array<Face, 6> makeFaces() {
  std::array<Face, 6> faces{};
  for (int a = 0; a < 3; ++a) {
    for (int s = 0; s < 2; ++s) {
      const int u = (a + 1) % 3, v = (a + 2) % 3;
      const int uv[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
      std::array<int, 4> corners{};
      for (int n = 0; n < 4; ++n) {
        int coord[3] = {0, 0, 0};
        coord[a] = s;
        coord[u] = uv[n][0];
        coord[v] = uv[n][1];
        corners[n] = cornerOf(coord[0], coord[1], coord[2]);
      }
      if (s == 0) corners = {corners[0], corners[3], corners[2], corners[1]};
      faces[a * 2 + s].corners = corners;
    }
  }
  return faces;
}

// Whether two cell edges lie on a common cube face.
constexpr bool shareFace(int a, int b) {
  const std::array<int, 3> sa = mcEdgeStart(a), sb = mcEdgeStart(b);
  for (int d = 0; d < 3; ++d)
    if (d != mcEdgeAxis(a) && d != mcEdgeAxis(b) && sa[d] == sb[d]) return true;
  return false;
}

struct GeneratedTable {
  std::array<McCase, 256> cases{};
  int maxTriangles = 0;
  bool valid = true;  // every crossing edge has exactly one successor and one predecessor
};

constexpr GeneratedTable generate() {
  GeneratedTable table;
  constexpr std::array<Face, 6> faces = makeFaces();
  for (int config = 0; config < 256; ++config) {
    const auto inside = [config](int c) { return ((config >> c) & 1) != 0; };
    // next[e]: the crossing where the segment entering at crossing e leaves its face.
    std::array<int, 12> next{};
    std::array<int, 12> incoming{};
    for (int e = 0; e < 12; ++e) next[e] = -1;
    for (const Face& face : faces) {
      for (int n = 0; n < 4; ++n) {
        const int prev = face.corners[(n + 3) % 4], cur = face.corners[n];
        if (!inside(cur) || inside(prev)) continue;  // n starts a maximal run of inside corners
        int last = n;
        while (inside(face.corners[(last + 1) % 4])) last = (last + 1) % 4;
        const int entering = edgeBetween(prev, cur);
        const int exiting = edgeBetween(face.corners[last], face.corners[(last + 1) % 4]);
        if (next[entering] != -1) table.valid = false;
        next[entering] = exiting;
        ++incoming[exiting];
      }
    }
    for (int e = 0; e < 12; ++e) {
      const bool crossing = inside(mcEdgeStartCorner(e)) != inside(mcEdgeEndCorner(e));
      if ((next[e] != -1) != crossing || incoming[e] != (crossing ? 1 : 0)) table.valid = false;
    }
    // Chain the segments into loops (each started at its lowest edge id) and fan them.
    McCase& out = table.cases[config];
    std::array<bool, 12> used{};
    int count = 0;
    for (int start = 0; start < 12; ++start) {
      if (next[start] == -1 || used[start]) continue;
      std::array<int, 12> loop{};
      int length = 0;
      for (int e = start; !used[e]; e = next[e]) {
        used[e] = true;
        loop[length++] = e;
      }
      // Fan root: the first loop vertex (from the lowest edge id on) whose diagonals join no two
      // crossings of one cube face. The neighbour across that face may fan through the same two
      // crossings, and the shared diagonal would then carry four triangles (non-manifold).
      int root = -1;
      for (int r = 0; r < length && root < 0; ++r) {
        bool clean = true;
        for (int i = 2; i + 1 < length; ++i)
          if (shareFace(loop[r], loop[(r + i) % length])) clean = false;
        if (clean) root = r;
      }
      if (root < 0) {
        table.valid = false;
        root = 0;
      }
      std::array<int, 12> fan{};
      for (int i = 0; i < length; ++i) fan[i] = loop[(root + i) % length];
      for (int i = 1; i + 1 < length; ++i) {
        if (count >= 6) {  // one more than the header allows: reported through maxTriangles
          table.valid = false;
          break;
        }
        if (count < 5) {
          out.edges[count * 3 + 0] = std::uint8_t(fan[0]);
          out.edges[count * 3 + 1] = std::uint8_t(fan[i]);
          out.edges[count * 3 + 2] = std::uint8_t(fan[i + 1]);
        }
        ++count;
      }
    }
    out.triangleCount = std::uint8_t(count);
    if (count > table.maxTriangles) table.maxTriangles = count;
  }
  return table;
}

constexpr GeneratedTable kTable = generate();
static_assert(kTable.valid,
              "marching-cubes rule produced an open or branching polygon, or a loop with no clean fan root");
static_assert(kTable.maxTriangles <= 5, "McCase::edges holds 5 triangles; the rule needs more");

}  // namespace

const std::array<McCase, 256>& marchingCubesCases() { return kTable.cases; }

}  // namespace blobvk::mesh
