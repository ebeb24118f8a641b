// The sparse extraction's layout (vk/extract/sparse_polygonizer.h), shared by its kernels.
// A brick holds B^3 cells (B = 1 << log2B, at most 16) and stores R^3 grid points, R = B + 1: its
// cells' corners. Brick-local point (x, y, z) is word (z * R + y) * R + x of the brick's slice of the
// per-point arrays; active brick a's slice starts at a * R^3. A point belongs to (is *owned by)
// the brick whose cells start at it, except on the grid's last point layer of an axis, which the
// last brick of that axis owns: each grid point has one owner, and a point's three upper edges lie
// inside its owner's points.
//
// Active bricks are numbered in (bz, by, bx) order (the exclusive scan of the classification's
// flags), so each row of bricks (bz, by) is a contiguous run of numbers: `rowStarts` holds each
// row's first (brick_row_starts.comp) and the active-brick list the bricks themselves. On a grid
// too large for one buffer the tables come in windows of whole brick layers (vk::ScanWindow):
// rows then count from the window's first layer and numbers from its first active brick; only
// differences of numbers matter.
// Rows of points (fixed y, z) of an active brick are *segments*; the global order of vertices
// (by edge key: point z, then y, then x) is the order of segments
//   [bz][local z][by][local y][k-th active brick of brick row (bz, by)],
// so a segment's position in that order (segmentOf) and one scan of the segments' vertex
// counts give every vertex its global index. Triangles (cell order) likewise with rows of cells.
#ifndef BLOBVK_BRICK_LAYOUT_GLSL
#define BLOBVK_BRICK_LAYOUT_GLSL

// q / d for quotients below 64 and d <= 2^12, without integer division (llvmpipe divides lane by
// lane): (q + 0.5) / d lies at least 0.5 / d from an integer, the float quotient within a few ulps
// of 64 of it.
uint divideSmall(uint q, uint d) {
  precise float quotient = (float(q) + 0.5) / float(d);  // precise: the kernels hold no contractible op
  return uint(quotient);
}

// The field samples of a batch (brick_field.comp writes them, the vertex kernels read them):
// point x of row `row` (a * R * R + r) at row * S + x, S = max(B, 4) floats a row so that each
// row starts on 16 bytes, and with B >= 4 the row's last point (x = B) at tailBase + row.
uint fieldIndex(uint row, uint x, uint log2B, uint tailBase) {
  uint S = max(1u << log2B, 4u);
  return x < S ? row * S + x : tailBase + row;
}

// Active bricks are listed by packed coordinates x | y << bx | z << (bx + by), bx and by the bits
// that the grid's bricks along x and y need (vk::BrickGrid::pack): any grid of at most 2^32 bricks
// packs in one word, however its bricks share out over the axes (4096^3 cells of a tall model in
// bricks of 4^3 takes 1025 bricks along one axis and fewer along the others).
uint brickBits(uint bricksOnAxis) { return uint(findMSB(bricksOnAxis - 1u) + 1); }  // findMSB(0) = -1
uint packBrick(uvec3 b, uvec2 bricksXY) {
  uint bx = brickBits(bricksXY.x), by = brickBits(bricksXY.y);
  return b.x | (b.y << bx) | (b.z << (bx + by));
}
uvec3 unpackBrick(uint packed, uvec2 bricksXY) {
  uint bx = brickBits(bricksXY.x), by = brickBits(bricksXY.y);
  return uvec3(packed & ((1u << bx) - 1u), (packed >> bx) & ((1u << by) - 1u), packed >> (bx + by));
}
// Bricks along x and y of a grid of `points` points per axis (edge keys): ceil(cells / B).
uvec2 bricksOfPoints(uvec2 points, uint log2B) { return (points + (1u << log2B) - 2u) >> log2B; }

// Vertices of a row of points before point x: e.x, e.y, e.z hold the row's crossing +x, +y, +z
// edges (bit x: point x's edge), and a point's vertices follow in axis order.
uint rowVerticesBefore(uvec3 e, uint x) {
  uint below = (1u << x) - 1u;
  return bitCount(e.x & below) + bitCount(e.y & below) + bitCount(e.z & below);
}

// The crossing upper edges that row (ly, lz) of points of a brick at grid cell g0 owns (bit x of
// .x, .y, .z: point x's +x, +y, +z edge), from the inside masks of the row (m) and of the next
// row in y (my) and in z (mz), the row itself where there is none. A row owns local x < B, and
// x = B on the grid's last point of the axis; none past the grid's end. Rows likewise in y and z.
uvec3 ownedRowEdges(uint m, uint my, uint mz, uvec3 cells, uvec3 g0, uint log2B, uint ly, uint lz) {
  uint B = 1u << log2B;
  uint gy = g0.y + ly, gz = g0.z + lz;
  uint xEnd = min(cells.x - g0.x, B);  // points x < xEnd have a +x edge in the grid
  uint owned = g0.x + B == cells.x ? (2u << B) - 1u : (1u << min(cells.x - g0.x + 1u, B)) - 1u;
  bool ownsRow = (ly < B || gy == cells.y) && (lz < B || gz == cells.z) && gy <= cells.y && gz <= cells.z;
  uvec3 e = uvec3(0u);
  if (ownsRow) {
    e.x = (m ^ (m >> 1)) & ((1u << xEnd) - 1u);
    e.y = gy < cells.y ? (m ^ my) & owned : 0u;
    e.z = gz < cells.z ? (m ^ mz) & owned : 0u;
  }
  return e;
}

// The row passes (brick_rows.comp, brick_sources.comp) run one invocation per *column* of rows,
// (brick, local y), walking local z: a row's inside mask and its +y neighbour's are the last
// step's +z ones, so each step loads two masks instead of four, and the brick's segment record
// is loaded once per column instead of once per row (llvmpipe runs every storage access as a
// loop over the lanes). MaskColumn holds the four masks of the current step.
struct MaskColumn {
  uint m, my, mz, myz;  // rows (y, z), (y + 1, z), (y, z + 1), (y + 1, z + 1); the row itself past the brick
};

// The marching-cubes configuration of cell x of the step's row of cells (corner bits as the CPU
// reference numbers them).
uint cellConfig(MaskColumn c, uint x) {
  return ((c.m >> x) & 3u) | (((c.my >> x) & 3u) << 2) | (((c.mz >> x) & 3u) << 4) | (((c.myz >> x) & 3u) << 6);
}

// Bit x: cell x of the step's row of cells has corners on both sides (configurations 0 and 255
// have no triangle): not all of the corners x and x + 1 of the four rows inside, nor all outside.
uint mixedCells(MaskColumn c) {
  uint all4 = c.m & c.my & c.mz & c.myz, any4 = c.m | c.my | c.mz | c.myz;
  return ~((all4 & (all4 >> 1)) | ~(any4 | (any4 >> 1)));
}

#ifdef MASKS_BINDING
layout(std430, set = 0, binding = MASKS_BINDING) readonly buffer Masks { uint masks[]; };  // brick_field.comp

// Column (ly) of the brick whose rows start at `rowBase` (row (ly, lz) is rowBase + lz * R + ly):
// the masks of its step lz = 0.
MaskColumn firstMaskStep(uint rowBase, uint ly, uint R) {
  uint dy = ly + 1u < R ? 1u : 0u;
  return MaskColumn(masks[rowBase + ly], masks[rowBase + ly + dy], masks[rowBase + R + ly], masks[rowBase + R + ly + dy]);
}

// From step lz to lz + 1 (< R): the +z rows become the current ones.
void nextMaskStep(inout MaskColumn c, uint rowBase, uint ly, uint lz, uint R) {
  c.m = c.mz;
  c.my = c.myz;
  if (lz + 2u < R) {  // the same for every lane of a step: no load at all on the last
    uint dy = ly + 1u < R ? 1u : 0u;
    c.mz = masks[rowBase + (lz + 2u) * R + ly];
    c.myz = masks[rowBase + (lz + 2u) * R + ly + dy];
  }
}
#endif

// The marching-cubes case table as a uniform buffer (vk::caseTableUniform): per configuration,
// x = triangle count, y = edges 0..7 and z = edges 8..14 (triangle k's edge i is edge 3k + i),
// four bits each. A uniform load at a per-lane index is one vector gather on llvmpipe; a storage
// load is a loop over the lanes with a bounds check each.
#ifdef CASES_BINDING
layout(std140, set = 0, binding = CASES_BINDING) uniform Cases { uvec4 cases[256]; };
uint caseEdge(uvec4 entry, uint j) { return j < 8u ? (entry.y >> (4u * j)) & 15u : (entry.z >> (4u * (j - 8u))) & 15u; }
#endif

// Where brick a's rows go in the segment order, as the per-row kernels read it in one load
// (brick_neighbours.comp writes it per brick of a batch): x = the brick's packed coordinates,
// y / z = the position of its row (0, 0) of points / of cells, counted from the batch's first
// segment, w = the active bricks in its slice (bz) | those in its row of bricks (bz, by) << 21.
// Row (rowY, rowZ) is then at base + rowZ * rows * slice + rowY * row (segmentOf): the bricks of
// a slice before this one's row come first at each local z, then those of its row at each local y.
uint segmentOf(uvec4 s, uint base, uint rows, uint rowY, uint rowZ) {
  return base + rowZ * rows * (s.w & 0x1fffffu) + rowY * (s.w >> 21);
}

#ifdef ROW_STARTS_BINDING
// The number of each brick row's first active brick in the window (brick_row_starts.comp): row
// (z, y) at (z - firstLayer) * bricks.y + y.
layout(std430, set = 0, binding = ROW_STARTS_BINDING) readonly buffer RowStarts { uint rowStarts[]; };

// segmentOf's record of active brick `a` (number in the window) at brick coordinates b, for a
// batch whose first active brick is activeBase; `coords` is the brick's packed coordinates,
// firstLayer the window's. Unsigned arithmetic wraps, the positions it gives are those of the
// whole order minus the batch's start.
uvec4 brickSegments(uint a, uint coords, uvec3 b, uvec3 bricks, uint activeBase, uint log2B, uint firstLayer) {
  uint B = 1u << log2B, R = B + 1u;
  uint slice = (b.z - firstLayer) * bricks.y;
  uint row = slice + b.y;
  uint sliceStart = rowStarts[slice], sliceCount = rowStarts[slice + bricks.y] - sliceStart;
  uint rowStart = rowStarts[row], rowCount = rowStarts[row + 1u] - rowStart;
  uint inRow = a - rowStart, beforeRow = rowStart - sliceStart;
  uint pointBase = R * R * sliceStart + R * beforeRow + inRow - activeBase * R * R;
  uint cellBase = B * B * sliceStart + B * beforeRow + inRow - activeBase * B * B;
  return uvec4(coords, pointBase, cellBase, sliceCount | (rowCount << 21));
}
#endif

#endif
