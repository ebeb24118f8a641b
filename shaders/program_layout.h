// The compiled BlobTree `Program` as bytes: one declaration read by C++ (the scalar reference and
// the AVX evaluators) and by GLSL (the compute shaders), so every backend runs the same records.
//
// Every record is a multiple of 16 bytes made only of 4-component vectors, so std430, std140 and
// the C++ layout agree without padding rules. The C++ side checks sizes with static_assert in
// blobtree/program.h. This file must stay valid GLSL 4.50 *and* C++20: no #pragma once, no
// C++-only syntax outside the __cplusplus block.
#ifndef BLOBVK_PROGRAM_LAYOUT_H
#define BLOBVK_PROGRAM_LAYOUT_H

#ifdef __cplusplus
#include <cstdint>
namespace blobvk::layout {
using uint = std::uint32_t;
struct vec4 { float x, y, z, w; };
struct uvec4 { uint x, y, z, w; };
#define BLOBVK_CONST inline constexpr
#else
#define BLOBVK_CONST const
#endif

// ---- Instructions --------------------------------------------------------------------------
// Instruction.x = opcode | (dst << 8). The meaning of y, z, w depends on the opcode:
//   OP_PRIM   reg[dst] = field of primitives[y] at point register z
//   OP_ADD    reg[dst] = reg[dst] + reg[y]                       (blend, and Ricci after OP_POW)
//   OP_MAX    reg[dst] = max(reg[dst], reg[y])                   (union)
//   OP_MIN    reg[dst] = min(reg[dst], reg[y])                   (intersection)
//   OP_DIFF   reg[dst] = min(reg[dst], 1 - reg[y])               (difference)
//   OP_SDIFF  reg[dst] = reg[dst] * (1 - reg[y])                 (smooth difference)
//   OP_POW    reg[dst] = pow(max(reg[dst], 0), uintBitsToFloat(w))  (Ricci power and root)
//   OP_WARP   point[dst] = warps[y](point[z])
//   OP_SKIP   if point[z] is outside boxes[y]: reg[dst] = 0, jump to instruction w
//   OP_ONE_MINUS reg[dst] = 1 - reg[dst]                         (a cutter evaluated first)
//   OP_MUL    reg[dst] = reg[dst] * reg[y]                       (smooth difference, reordered)
//   OP_NULL_ADDS  (vertex tapes only, vk/eval/region_tape.h) w pairs of a primitive that is 0 in
//             the region and the OP_ADD of it into reg[dst], with their bits: reg[dst] + 0, the
//             gradient plus signed zeros (bit j of z set: component j adds -0), the colour blended
//             with weight 0 until it stops changing (y: one of the primitives, for its colour)
// Colour (when wanted) follows the field: OP_PRIM sets the primitive's colour; OP_ADD blends
// the two colours weighted by max(field, 0); OP_MAX/OP_MIN keep the colour of the operand that
// wins; OP_DIFF/OP_SDIFF take the cutter's colour where 1 - reg[y] < reg[dst]; OP_MUL the colour
// of the smaller operand; OP_POW/OP_ONE_MINUS keep it; a taken OP_SKIP writes colour 0.
// Difference and smooth difference are emitted as OP_DIFF/OP_SDIFF when their first child is
// evaluated first, else as OP_ONE_MINUS on each cutter plus OP_MIN/OP_MUL, which keeps the
// register count logarithmic for every tree shape.
// Field registers hold the field (and, when colour is wanted, a colour per register). Point
// register 0 is the query point; warps write the registers above it.
BLOBVK_CONST uint OP_PRIM = 1u;
BLOBVK_CONST uint OP_ADD = 2u;
BLOBVK_CONST uint OP_MAX = 3u;
BLOBVK_CONST uint OP_MIN = 4u;
BLOBVK_CONST uint OP_DIFF = 5u;
BLOBVK_CONST uint OP_SDIFF = 6u;
BLOBVK_CONST uint OP_POW = 7u;
BLOBVK_CONST uint OP_WARP = 8u;
BLOBVK_CONST uint OP_SKIP = 9u;
BLOBVK_CONST uint OP_ONE_MINUS = 10u;
BLOBVK_CONST uint OP_MUL = 11u;
BLOBVK_CONST uint OP_NULL_ADDS = 12u;

BLOBVK_CONST uint MAX_FIELD_REGISTERS = 32u;  // Sethi-Ullman needs log2(nodes)+1: ample
BLOBVK_CONST uint MAX_POINT_REGISTERS = 8u;   // warp nesting depth + 1

// ---- Primitives ----------------------------------------------------------------------------
// Parameters are in the primitive's unit frame: distances there are already divided by the
// support radius, so the kernel is (1 - dd)^3 on the squared distance dd.
//   PRIM_POINT      p0.xyz centre
//   PRIM_LINE       p0.xyz start a, p1.xyz (b - a), p1.w 1/|b - a|^2 (0 for a degenerate segment)
//   PRIM_CYLINDER   p0.xyz base centre, p1.xyz unit axis, p2.x radius, p2.y height
//   PRIM_DISC       p0.xyz centre, p1.xyz unit normal, p2.x radius
//   PRIM_RING       p0.xyz centre, p1.xyz unit normal, p2.x radius
//   PRIM_CUBE       p0.xyz centre, p1.xyz half extents
//   PRIM_TRIANGLE   p0.xyz, p1.xyz, p2.xyz corners
//   PRIM_QUADRIC    p0.xyz centre, p0.w scale S: field S (1 - dd)^2
// meta.x type, meta.y matrix index (0 = identity, skip the multiply), meta.z colour RGBA8.
BLOBVK_CONST uint PRIM_POINT = 0u;
BLOBVK_CONST uint PRIM_LINE = 1u;
BLOBVK_CONST uint PRIM_CYLINDER = 2u;
BLOBVK_CONST uint PRIM_DISC = 3u;
BLOBVK_CONST uint PRIM_RING = 4u;
BLOBVK_CONST uint PRIM_CUBE = 5u;
BLOBVK_CONST uint PRIM_TRIANGLE = 6u;
BLOBVK_CONST uint PRIM_QUADRIC = 7u;

// ---- Warps ---------------------------------------------------------------------------------
// meta.x type, meta.y axis a, meta.z axis b, meta.w matrix index applied to the point first.
//   WARP_TWIST  rotate the plane normal to axis a by angle params.x * p[a]
//   WARP_TAPER  p[b] *= 1 + params.x * p[a]
//   WARP_BEND   bend along axis a towards axis b: rate params.x, centre params.y,
//               bent region [params.z, params.w] along a
//   WARP_SHEAR  p[a] += params.x * p[b]
BLOBVK_CONST uint WARP_TWIST = 0u;
BLOBVK_CONST uint WARP_TAPER = 1u;
BLOBVK_CONST uint WARP_BEND = 2u;
BLOBVK_CONST uint WARP_SHEAR = 3u;

BLOBVK_CONST float ISO_VALUE = 0.5;
// A vertex's parameter t on its edge is kept within [CROSSING_MIN, CROSSING_MAX] (2^-12 of the
// edge from either end): a sample exactly at ISO_VALUE would otherwise put the vertices of all
// its crossing edges on that one grid point, and their triangles would have no area (STL readers,
// which weld by position, then see non-manifold edges). min/max are exact, so every backend
// keeps the same bits.
BLOBVK_CONST float CROSSING_MIN = 0.000244140625;
BLOBVK_CONST float CROSSING_MAX = 0.999755859375;

struct Instruction {
  uvec4 code;  // see OP_*
};

struct PrimitiveRecord {
  vec4 p0;
  vec4 p1;
  vec4 p2;
  uvec4 meta;
};

// World->local affine map, rows of a 3x4 matrix: local = (dot(r0, p1), dot(r1, p1), dot(r2, p1))
// with p1 = (p, 1).
struct MatrixRecord {
  vec4 r0;
  vec4 r1;
  vec4 r2;
};

// Axis-aligned box in the coordinates of the point register the skip tests.
struct BoxRecord {
  vec4 lo;
  vec4 hi;
};

struct WarpRecord {
  uvec4 meta;
  vec4 params;
};

#ifdef __cplusplus
#undef BLOBVK_CONST
}  // namespace blobvk::layout
#else
#undef BLOBVK_CONST
#endif

#endif  // BLOBVK_PROGRAM_LAYOUT_H
