// Included by vertices.comp and vertices_tiled.comp after eval_program.glsl and common.glsl:
// their shared bindings, push constants and the work of one vertex. Position, refinement, normal
// and colour by the rules of cpu_simd/reference_polygonizer.cpp: t = (iso - fa) / (fb - fa) from
// the edge's lower point, optional Illinois regula-falsi steps, then normal (-gradient,
// normalised) and colour from one analytic-gradient pass (eval_gradient.glsl, as
// blobtree::evaluateGradientColour). The stack-based traversal, whose code buffer holds a tree
// encoding, keeps central differences (blobtree::normal) and the colour evaluator.
#ifndef BLOBVK_VERTEX_EMIT_GLSL
#define BLOBVK_VERTEX_EMIT_GLSL

#include "eval_gradient.glsl"

#ifdef BLOBVK_EVAL_INTERPRETER
#define STACK_TRAVERSAL (TRAVERSAL == 1u)
#else
#define STACK_TRAVERSAL false  // the specialised evaluator
#endif

layout(std430, set = 0, binding = 5) readonly buffer Field { float field[]; };
layout(std430, set = 0, binding = 6) readonly buffer Flags { uint flags[]; };
layout(std430, set = 0, binding = 7) readonly buffer VertexOffsets { uint vertexOffsets[]; };
layout(std430, set = 0, binding = 8) writeonly buffer Positions { float positions[]; };
layout(std430, set = 0, binding = 9) writeonly buffer Normals { float normals[]; };
layout(std430, set = 0, binding = 10) writeonly buffer Colours { float colours[]; };
layout(std430, set = 0, binding = 11) writeonly buffer Keys { uint keys[]; };
layout(std430, set = 0, binding = 12) readonly buffer Args { uint args[]; };  // draw_args.comp

layout(push_constant) uniform Push {
  vec4 originCell;
  uint nx, ny;
  uint ownedPoints;  // owned points of the slab
  uint k0;
  uint codeLength;
  uint refineSteps;
  uint attributes;   // bit 0 normals, bit 1 colours
  float normalStep;  // central-difference step h
  uint vertexBase;   // vertices of the slabs before this one
  // vertices_tiled.comp only: the tile's points of this slab (x i0 .. i0 + tileNx - 1,
  // y j0 .. j0 + tileNy - 1, slab-local layers layer0 ..), its rows in the row scan and its
  // slot in the tile arguments.
  uint tileI0, tileNx, tileJ0, tileNy, tileLayer0, rowBase, rows, tileIndex;
  uint vertexCapacity;  // vertices the output buffers hold (slab-local); later ones are dropped
} pc;

precise vec3 gridPoint(uint i, uint j, uint k) {  // precise: no fma, as GridSpec::point
  return pc.originCell.xyz + pc.originCell.w * vec3(float(i), float(j), float(k));
}

// Vertex v of the slab (slab-local), on a crossing upper edge of point idx (slab-local).
void emitVertex(uint v, uint idx) {
  // Beyond the caller's buffers: emit_limits.comp has flagged the overflow.
  if (v >= pc.vertexCapacity) return;
  uint bits = flags[idx];
  uint rank = v - vertexOffsets[idx];
  uint axis = findLSB(bits);
  if (rank > 0u) {
    bits &= bits - 1u;
    axis = findLSB(bits);
  }
  if (rank > 1u) {
    bits &= bits - 1u;
    axis = findLSB(bits);
  }
  uint i = idx % pc.nx, j = (idx / pc.nx) % pc.ny, k = pc.k0 + idx / (pc.nx * pc.ny);
  uint out_ = v;
  vec3 pa = gridPoint(i, j, k);
  float fa = field[idx];
  {
    uvec3 step_ = uvec3(axis == 0u ? 1u : 0u, axis == 1u ? 1u : 0u, axis == 2u ? 1u : 0u);
    uint nb = idx + (axis == 0u ? 1u : (axis == 1u ? pc.nx : pc.nx * pc.ny));
    vec3 pb = gridPoint(i + step_.x, j + step_.y, k + step_.z);
    float fb = field[nb];
    // cpu/reference_polygonizer.cpp rule 2: only the edge's own coordinate moves.
    float len = pb[axis] - pa[axis];
    precise float t = (ISO_VALUE - fa) / (fb - fa);
    precise float lo = 0.0, hi = 1.0, flo = fa, fhi = fb;
    int keptSide = 0;  // Illinois regula falsi: -1 lo kept last step, +1 hi kept last step
    for (uint s = 0u; s < pc.refineSteps; ++s) {
      precise vec3 q = pa;
      q[axis] = pa[axis] + t * len;
      float f = evaluateField(q, pc.codeLength);
      if (f == ISO_VALUE) break;
      if ((f >= ISO_VALUE) == (flo >= ISO_VALUE)) {
        lo = t;
        flo = f;
        if (keptSide == 1) fhi = ISO_VALUE + (fhi - ISO_VALUE) * 0.5;
        keptSide = 1;
      } else {
        hi = t;
        fhi = f;
        if (keptSide == -1) flo = ISO_VALUE + (flo - ISO_VALUE) * 0.5;
        keptSide = -1;
      }
      t = lo + (ISO_VALUE - flo) / (fhi - flo) * (hi - lo);
    }
    precise vec3 p = pa;
    p[axis] = pa[axis] + t * len;
    uint v = out_ * 3u;
    positions[v] = p.x;
    positions[v + 1u] = p.y;
    positions[v + 2u] = p.z;
    if (!STACK_TRAVERSAL && pc.attributes != 0u) {
      vec3 g, colour;
      evaluateGradient(p, pc.codeLength, (pc.attributes & 2u) != 0u, g, colour);
      if ((pc.attributes & 1u) != 0u) {
        float len = length(g);
        precise vec3 nrm = len > 0.0 ? -g / len : vec3(0.0, 0.0, 1.0);
        normals[v] = nrm.x;
        normals[v + 1u] = nrm.y;
        normals[v + 2u] = nrm.z;
      }
      if ((pc.attributes & 2u) != 0u) {
        colours[v] = colour.x;
        colours[v + 1u] = colour.y;
        colours[v + 2u] = colour.z;
      }
    }
    if (STACK_TRAVERSAL && (pc.attributes & 1u) != 0u) {
      float h = pc.normalStep;
      float inv = 0.5 / h;
      precise vec3 g = vec3((evaluateField(p + vec3(h, 0, 0), pc.codeLength) - evaluateField(p - vec3(h, 0, 0), pc.codeLength)) * inv,
                    (evaluateField(p + vec3(0, h, 0), pc.codeLength) - evaluateField(p - vec3(0, h, 0), pc.codeLength)) * inv,
                    (evaluateField(p + vec3(0, 0, h), pc.codeLength) - evaluateField(p - vec3(0, 0, h), pc.codeLength)) * inv);
      float len = length(g);
      precise vec3 nrm = len > 0.0 ? -g / len : vec3(0.0, 0.0, 1.0);
      normals[v] = nrm.x;
      normals[v + 1u] = nrm.y;
      normals[v + 2u] = nrm.z;
    }
    if (STACK_TRAVERSAL && (pc.attributes & 2u) != 0u) {
      vec3 colour;
      evaluateFieldColour(p, pc.codeLength, colour);
      colours[v] = colour.x;
      colours[v + 1u] = colour.y;
      colours[v + 2u] = colour.z;
    }
    keys[out_] = idx * 3u + axis;
  }
}

#endif
