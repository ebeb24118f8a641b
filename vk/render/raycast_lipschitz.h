// A Lipschitz bound of a compiled Program's field over a region: |f(p) - f(q)| <= L |p - q| for
// p, q in `region`. The ray-caster steps (iso - f) / L, which can never step over the surface.
// Derivation (docs/rendering.md, "Ray-casting"):
//  - a primitive is (1 - d^2)^3 of a 1-Lipschitz distance d in its unit frame: slope at most
//    max 6 d (1 - d^2)^2 = 96 / (25 sqrt 5) ~ 1.717, times the largest stretch of its world->local
//    matrix (bounded by the Frobenius norm of its 3x3 part); quadrics S (1 - d^2)^2: 8 S / (3 sqrt 3);
//  - blend (add) sums bounds; union, intersection, difference keep the larger; products
//    (smooth difference) use |a b|' <= |a| L_b + |b| L_a with value bounds tracked alongside;
//    the Ricci pair pow(., p) ... pow(., 1/p) is the p-norm of the children, no steeper than
//    their sum, so pow is treated as transparent and add sums;
//  - a warp multiplies the bound of everything evaluated at its output point by the largest
//    stretch of the warp over the region (twist about axis a 1 + |k| R_uv, taper 1 + |k| (R_a +
//    R_b), bend 2 + |k| |R|, shear 1 + |k|), R the per-axis largest coordinate magnitude
//    reachable in the region (R_uv: the largest distance from the twist's axis).
#pragma once

#include "blobvk/blobtree/program.h"

#include <cstdint>
#include <vector>

namespace blobvk::vk {

struct LipschitzBound {
  float lipschitz = 0.0f;  // L over the region
  float maxValue = 0.0f;   // bound of |f|
};

// Primitives reading world points (point register 0) whose Program::primitiveBoxes miss the
// region are 0 throughout it: they add neither slope nor value there.
LipschitzBound lipschitzBound(const blobtree::Program& program, const blobtree::Aabb& region);

// Per-region bounds: the region split into dims[0] x dims[1] x dims[2] cells (x fastest), each
// with the bound of lipschitzBound over that cell. A far, steep component then raises the step
// bound only in the cells its support box reaches, not along every ray of the scene.
struct LipschitzGrid {
  blobtree::Aabb region;
  std::uint32_t dims[3] = {1, 1, 1};
  std::vector<float> cells;  // L per cell; 0 where the field is constant (0) in the cell
  float largest() const;
};

// Cells roughly cubic, at most maxCellsPerAxis along the longest side, and fewer when cells times
// instructions would pass maxWork (the bounds are one pass over the program per cell, on the CPU).
LipschitzGrid lipschitzGrid(const blobtree::Program& program, const blobtree::Aabb& region,
                            std::uint32_t maxCellsPerAxis = 64, std::uint64_t maxWork = 8u << 20);

}  // namespace blobvk::vk
