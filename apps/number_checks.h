// CLI11 checks for floating-point options (and one for text). CLI::Range and CLI::PositiveNumber let NaN through
// (every comparison with it is false), so `--cell-size nan` reached the work and failed there
// as an error (exit 1) instead of a usage error (exit 2). These refuse NaN, infinities and values
// a float cannot hold (beyond its range, or so small they would round to zero).
#pragma once

#include <CLI/CLI.hpp>

#include <array>
#include <string>

namespace blobvk::app {

// A finite number in [lo, hi].
CLI::Validator finiteRange(double lo, double hi);
// A finite number > 0.
CLI::Validator positiveFinite();
// A grid cell size: > 0 and at most the scene format's largest value, 1e6.
CLI::Validator cellSize();
// A finite number >= 0.
CLI::Validator nonNegativeFinite();
// Cells per MPU side: 0 (the default) or 2 to 64 (an MPU of one cell holds no interior corner).
CLI::Validator mpuCells();
// Grid bounds "x0,y0,z0,x1,y1,z1": six finite numbers within the scene format's range (1e6),
// x0 < x1, y0 < y1, z0 < z1 (the scene format's grid.bounds).
CLI::Validator gridBounds();
// The six numbers of a text gridBounds() accepted.
std::array<double, 6> parseGridBounds(const std::string& text);
// Any text but the empty one: `--device ''` or `--simplify ''` would otherwise read as the
// option not given.
CLI::Validator nonEmptyText();

}  // namespace blobvk::app
