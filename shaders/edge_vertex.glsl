// The vertex on one crossing grid edge, by the rules of cpu_simd/reference_polygonizer.cpp:
// t = (iso - fa) / (fb - fa) from the edge's lower point, kept within [CROSSING_MIN, CROSSING_MAX]
// (shaders/program_layout.h), optional Illinois regula-falsi steps (each t kept so too),
// then normal (-gradient, normalised) and colour from one analytic-gradient pass (eval_gradient.glsl,
// as blobtree::evaluateGradientColour). The stack-based traversal, whose code buffer holds a tree
// encoding, keeps central differences (blobtree::normal) and the colour evaluator.
// Included after eval_program.glsl by the vertex kernels (vertex_emit.glsl), which declare `pc`
// (originCell, codeLength, refineSteps, attributes bit 0 normals bit 1 colours, normalStep) and
// the float arrays positions, normals and colours.
//
// The field is evaluated at ONE call site, in a loop over the samples (refinement steps, then, for
// the stack-based traversal, the six normal samples): drivers inline every call, so a specialised
// kernel (vk/eval/program_codegen.h) holds one copy of the generated field evaluator.
// The arithmetic is that of the straight-line form operation for operation (same sample points,
// same differences), so meshes do not change.
#ifndef BLOBVK_EDGE_VERTEX_GLSL
#define BLOBVK_EDGE_VERTEX_GLSL
// Where the evaluators' code ends: the program's length, or a per-brick tape's end (EVAL_TAPES).
#ifndef EVAL_CODE_END
#define EVAL_CODE_END pc.codeLength
#endif

#include "eval_gradient.glsl"

#ifndef STACK_TRAVERSAL
#ifdef BLOBVK_EVAL_INTERPRETER
#define STACK_TRAVERSAL (TRAVERSAL == 1u)
#else
#define STACK_TRAVERSAL false  // the specialised evaluator
#endif
#endif

precise vec3 gridPoint(uint i, uint j, uint k) {  // precise: no fma, as GridSpec::point
  return pc.originCell.xyz + pc.originCell.w * vec3(float(i), float(j), float(k));
}

// Vertex `out_` on the edge from grid point g along `axis`, fa and fb the field at its ends.
void emitEdgeVertex(uint out_, uvec3 g, uint axis, float fa, float fb) {
  vec3 pa = gridPoint(g.x, g.y, g.z);
  uvec3 step_ = uvec3(axis == 0u ? 1u : 0u, axis == 1u ? 1u : 0u, axis == 2u ? 1u : 0u);
  vec3 pb = gridPoint(g.x + step_.x, g.y + step_.y, g.z + step_.z);
  // cpu/reference_polygonizer.cpp rule 2: only the edge's own coordinate moves.
  float len = pb[axis] - pa[axis];
  precise float t = clamp((ISO_VALUE - fa) / (fb - fa), CROSSING_MIN, CROSSING_MAX);
  precise float lo = 0.0, hi = 1.0, flo = fa, fhi = fb;
  int keptSide = 0;  // Illinois regula falsi: -1 lo kept last step, +1 hi kept last step
  float h = pc.normalStep;
  // Samples: refinement steps first (while `refining`), then normal samples 0..5 at
  // p + h e_a, p - h e_a for a = x, y, z (none when normals are off).
  bool refining = pc.refineSteps > 0u;
  uint steps = 0u;
  uint normalSamples = (STACK_TRAVERSAL && (pc.attributes & 1u) != 0u) ? 6u : 0u;
  uint n = 0u;
  float inv = 0.5 / h;
  float fPlus = 0.0;  // the last p + h e_a sample
  precise vec3 grad = vec3(0.0);
  precise vec3 p = pa;
  p[axis] = pa[axis] + t * len;
#ifndef EDGE_VERTEX_NO_SAMPLES  // defined by kernels that take no sample (brick_vertices_direct.comp)
  for (;;) {
    if (!refining && n >= normalSamples) break;
    // p + (±h on axis a, 0 elsewhere): the sums blobtree::normal forms (x - h == x + -h), by
    // selects rather than a dynamically indexed component (a per-lane gather on llvmpipe).
    uint a = n >> 1u;
    float s = refining ? 0.0 : ((n & 1u) == 0u ? h : -h);
    vec3 q = p + vec3(a == 0u ? s : 0.0, a == 1u ? s : 0.0, a == 2u ? s : 0.0);
    float f = evaluateField(q, EVAL_CODE_END);
    if (!refining) {
      if ((n & 1u) == 0u) {
        fPlus = f;
      } else {
        float d = (fPlus - f) * inv;
        grad = vec3(a == 0u ? d : grad.x, a == 1u ? d : grad.y, a == 2u ? d : grad.z);
      }
      ++n;
      continue;
    }
    ++steps;
    if (f == ISO_VALUE) {
      refining = false;
      continue;
    }
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
    t = clamp(lo + (ISO_VALUE - flo) / (fhi - flo) * (hi - lo), CROSSING_MIN, CROSSING_MAX);
    p[axis] = pa[axis] + t * len;
    if (steps >= pc.refineSteps) refining = false;
  }
#endif
  uint v = out_ * 3u;
  positions[v] = p.x;
  positions[v + 1u] = p.y;
  positions[v + 2u] = p.z;
  if (!STACK_TRAVERSAL && pc.attributes != 0u) {
    vec3 g, colour;
    evaluateGradient(p, EVAL_CODE_END, (pc.attributes & 2u) != 0u, g, colour);
    if ((pc.attributes & 1u) != 0u) {
      float glen = length(g);
      precise vec3 nrm = glen > 0.0 ? -g / glen : vec3(0.0, 0.0, 1.0);
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
    float glen = length(grad);
    precise vec3 nrm = glen > 0.0 ? -grad / glen : vec3(0.0, 0.0, 1.0);
    normals[v] = nrm.x;
    normals[v + 1u] = nrm.y;
    normals[v + 2u] = nrm.z;
  }
#ifndef EVALUATOR_GRADIENT_ONLY  // kernels without the stack-based traversal (brick_vertices_direct.comp)
  if (STACK_TRAVERSAL && (pc.attributes & 2u) != 0u) {
    vec3 colour;
    evaluateFieldColour(p, EVAL_CODE_END, colour);
    colours[v] = colour.x;
    colours[v + 1u] = colour.y;
    colours[v + 2u] = colour.z;
  }
#endif
}

#endif
