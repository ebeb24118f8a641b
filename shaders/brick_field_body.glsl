// The body of the sparse field pass (brick_field.comp; brick_field_tapes.comp with EVAL_TAPES: each
// brick interprets its own tape, the program pruned to the brick on the host).
// Sparse extraction, pass 3: the field at the R^3 points of every active brick (brick_layout.glsl)
// and, per row of points, the inside bits (f >= iso, as in the CPU reference) packed into bit x of
// one word, which every later pass reads instead of the field (llvmpipe pays a load per lane per
// float; a row's crossing edges and cell configurations are a few bit operations on four words).
// One invocation per row of points (y + z * R): it evaluates the row's R points in a loop, so the
// row's word is built in registers instead of by a pass reading R floats back. Point (x, y, z) of
// the brick is grid point brick * B + (x, y, z) (points past the grid's end are evaluated too and
// never read). Invocation x is the row, y + z * (groups in y) the i-th brick of this dispatch,
// active brick order[orderBase + i]: the host dispatches once per field tile (vk/extract/
// brick_tiles.h), each with an evaluator pruned to its bricks. One work group spans a brick's rows
// (R^2 rounded up to a vector of 8: few idle lanes, which llvmpipe would run through the whole
// evaluator). The same point formula as GridSpec::point: origin + h * (i, j, k).
// The samples (brick_layout.glsl, fieldIndex): a row's points x < B in a run of S = max(B, 4)
// floats that starts on 16 bytes, stored four at a time as a vec4 (llvmpipe runs each store
// instruction as a loop over the lanes, whatever its width: 5 stores a row of 17 instead of 17),
// and its last point (x = B) in the tail at tailBase + row, through a second binding of the same
// buffer.
#ifndef BLOBVK_BRICK_FIELD_BODY_GLSL
#define BLOBVK_BRICK_FIELD_BODY_GLSL
#define EVALUATOR_FIELD_ONLY  // calls evaluateField alone (eval_program.glsl)
#define PROGRAM_SET 0
#define PROGRAM_BINDING 0
#include "eval_program.glsl"
#include "common.glsl"

layout(std430, set = 0, binding = 5) readonly buffer Bricks { uint bricks[]; };  // packed coordinates
layout(std430, set = 0, binding = 6) writeonly buffer FieldQuads { vec4 fieldQuads[]; };
layout(std430, set = 0, binding = 7) writeonly buffer Masks { uint masks[]; };
#ifdef FIELD_ROW_LIST
// brick_field_rows.comp: the rows to evaluate, by tile (vk/extract/row_culling.h): batch brick << 9 |
// row, then the span of segments to evaluate and the inside bits of the row's other points.
layout(std430, set = 0, binding = 8) readonly buffer Rows { uvec2 rowList[]; };
#else
layout(std430, set = 0, binding = 8) readonly buffer Order { uint order[]; };  // batch brick numbers by tile
#endif
layout(std430, set = 0, binding = 9) writeonly buffer FieldTail { float fieldTail[]; };  // binding 6's buffer
#ifdef EVAL_TAPES
// Per batch brick, its tape's first instruction and end (vk/extract/brick_tapes.h).
layout(std430, set = 0, binding = 10) readonly buffer BrickTapes { uvec2 brickTapes[]; };
#endif

#include "brick_layout.glsl"

layout(push_constant) uniform Push {
  vec4 originCell;
  uint log2B;
  uint activeBricks;  // bricks of this dispatch (with FIELD_ROW_LIST: rows)
  uint codeLength;
  uint orderBase;     // this dispatch's first entry of `order` (of `rowList`)
  uint tailBase;      // where the rows' last samples start (floats)
  uint bricksX, bricksY;  // bricks along x and y (packed brick coordinates)
} pc;

void main() {
  uint R = (1u << pc.log2B) + 1u;
#ifdef FIELD_ROW_LIST
  // One lane per listed row, in a 2-D dispatch of work groups (vk::groupsFor).
  uint e = linearInvocation();
  if (e >= pc.activeBricks) return;
  uvec2 entry = rowList[pc.orderBase + e];
  uint a = entry.x >> 9, r = entry.x & 511u;
#else
  uint r = gl_GlobalInvocationID.x;
  uint i = gl_GlobalInvocationID.y + gl_GlobalInvocationID.z * gl_NumWorkGroups.y;
  if (r >= R * R || i >= pc.activeBricks) return;
  uint a = order[pc.orderBase + i];
#endif
  uint z = divideSmall(r, R), y = r - z * R;
  uvec3 g = (unpackBrick(bricks[a], uvec2(pc.bricksX, pc.bricksY)) << pc.log2B) + uvec3(0u, y, z);
  uint row = a * R * R + r;
  uint B = R - 1u, S = max(B, 4u);
#ifdef EVAL_TAPES
  // One brick per work group: the tape is the same for every lane (eval_program.glsl).
  uvec2 tape = brickTapes[a];
  evalTapeBegin = tape.x;
  uint codeEnd = tape.y;
#else
  uint codeEnd = pc.codeLength;
#endif
#ifdef FIELD_ROW_LIST
  // The listed span: points first .. last, from segment (entry.y >> 17) & 7 on, over
  // (entry.y >> 20) & 7 segments of four cells; the other points' inside bits come with the entry.
  uint m = entry.y & 0x1ffffu;
  uint first = ((entry.y >> 17) & 7u) << 2;
  uint last = first + (((entry.y >> 20) & 7u) << 2);
#else
  uint m = 0u;
  uint first = 0u, last = B;
#endif
  // Runs of four points, each evaluated in an inner loop (one call site of the evaluator: drivers
  // inline every call) and stored as one vec4 while it lies in the row's run of S floats (for
  // B = 2 the run holds all three points and a float of padding); with B >= 4 the last run is
  // the span's last point alone, stored after the loop: in the tail where it is the row's last,
  // else as the first float of its run.
  vec4 quad = vec4(0.0);
  for (uint x0 = first; x0 <= last; x0 += 4u) {
    uint n = min(4u, last + 1u - x0);
    for (uint j = 0u; j < n; ++j) {
      uint x = x0 + j;
      precise vec3 p = pc.originCell.xyz + pc.originCell.w * vec3(float(g.x + x), float(g.y), float(g.z));  // no fma
      float f = evaluateField(p, codeEnd);
      quad = vec4(j == 0u ? f : quad.x, j == 1u ? f : quad.y, j == 2u ? f : quad.z, j == 3u ? f : quad.w);
      if (f >= ISO_VALUE) m |= 1u << x;
    }
    if (x0 < last) fieldQuads[(row * S + x0) >> 2] = quad;
  }
  if ((last & 3u) == 0u) fieldTail[last < S ? row * S + last : pc.tailBase + row] = quad.x;
  masks[row] = m;
}

#endif
