#include "blobvk/cpu_simd/column_sides.h"

#include "blobvk/cpu_simd/block_bounds.h"
#include "blobvk/cpu_simd/tape_pruning.h"

#include <tbb/enumerable_thread_specific.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <map>
#include <vector>

namespace blobvk::cpu {
namespace {

// The program is pruned in two steps: to a coarse cell of this many boxes a side, kept for the
// thread's next boxes there, then to the box from the cell's tape. Pruning the whole program box
// by box costs more than bounding the box's columns where a program has many primitives and no
// skips to prune by (random128 at 512 cells: 6,665 bricks, its 128 primitives tested against each).
constexpr double kCellBoxes = 4.0;
// A thread keeps the tapes of this many cells (a batch's bricks come row by row).
constexpr std::size_t kCellsKept = 256;

}  // namespace

struct ColumnSides::State {
  struct PerThread {
    bool ready = false;
    blobtree::Program cell;  // makeTapeProgram(program): its code the current cell's tape
    blobtree::Program box;   // makeTapeProgram(cell): its code the box's tape
    std::map<std::array<std::int64_t, 6>, std::vector<layout::Instruction>> cells;  // cell, box size -> tape
    std::array<std::int64_t, 6> current{};
    bool haveCurrent = false;
    BlockBounds bounds;
    std::vector<double> cx, cy, cz, lo, hi;
    std::vector<std::size_t> crossing;  // columns that may cross, whose segments are bounded
  };
  explicit State(const blobtree::Program& program) : tapeTemplate(makeTapeProgram(program)) {}
  blobtree::Program tapeTemplate;
  tbb::enumerable_thread_specific<PerThread> threads;
};

namespace {
bool hasPow(const blobtree::Program& program) {
  return std::any_of(program.code.begin(), program.code.end(),
                     [](const layout::Instruction& in) { return (in.code.x & 0xffu) == layout::OP_POW; });
}
}  // namespace

bool ColumnSides::boundsHoldOnIeeeDevices(const blobtree::Program& program) {
  for (const layout::Instruction& in : program.code) {
    if ((in.code.x & 0xffu) != layout::OP_POW) continue;
    // A power whose result a device may flush to 0 where the CPU keeps the smallest normal float
    // (or the reverse) moves a Ricci blend by up to 2^(-126/e): at most half the margin.
    const double e = std::bit_cast<float>(in.code.w);
    if (!(e > 0.0) || std::exp2(-126.0 / e) > 0.5 * kPowDeviceMargin) return false;
  }
  // Twists and bends: their bounds keep a margin for the device's sin and cos (field_bounds.cpp).
  return true;
}

ColumnSides::ColumnSides(const blobtree::Program& program)
    : program_(program), margin_(hasPow(program) ? kPowDeviceMargin : 0.0), state_(std::make_unique<State>(program)) {}
ColumnSides::~ColumnSides() = default;

void ColumnSides::operator()(const float* x, std::uint32_t nx, const float* y, const float* z, std::uint32_t n,
                             std::uint8_t* sides) const {
  State::PerThread& t = state_->threads.local();
  if (!t.ready) {  // the records, once per thread; pruning rewrites code only
    t.cell = state_->tapeTemplate;
    t.box = makeTapeProgram(t.cell);
    t.ready = true;
  }
  const glm::dvec3 lo(x[0], y[0], z[0]), hi(x[nx], y[n], z[n]);
  const glm::dvec3 size = hi - lo;
  // The coarse cell holding the box's low corner, grown by a box size and a hundredth so that it
  // holds the box whatever rounding gave its coordinates (a degenerate box may still miss it).
  std::array<std::int64_t, 6> key{};
  glm::dvec3 cellLo{0.0}, cellHi{0.0};
  bool inCell = true;
  for (int a = 0; a < 3; ++a) {
    const double span = kCellBoxes * size[a];
    const double index = span > 0.0 ? std::floor(lo[a] / span) : 0.0;
    key[std::size_t(a)] = std::int64_t(index);
    std::memcpy(&key[std::size_t(3 + a)], &size[a], sizeof(double));
    cellLo[a] = index * span - 0.01 * size[a];
    cellHi[a] = (index + 1.0) * span + 1.01 * size[a];
    inCell = inCell && cellLo[a] <= lo[a] && hi[a] <= cellHi[a];
  }
  if (!inCell) {  // never with grid coordinates; then the box is pruned on its own, uncached
    specialiseTape(program_, lo, hi, TapeUse::Field, t.cell);
    t.haveCurrent = false;
  } else if (!t.haveCurrent || key != t.current) {
    auto it = t.cells.find(key);
    if (it != t.cells.end()) {
      t.cell.code = it->second;
    } else {
      if (t.cells.size() >= kCellsKept) t.cells.clear();
      specialiseTape(program_, cellLo, cellHi, TapeUse::Field, t.cell);
      t.cells.emplace(key, t.cell.code);
    }
    t.current = key;
    t.haveCurrent = true;
  }
  specialiseTape(t.cell, lo, hi, TapeUse::Field, t.box);
  t.bounds.reset(t.box, lo, hi);
  const double below = layout::ISO_VALUE - margin_, above = layout::ISO_VALUE + margin_;
  auto sideOf = [below, above](double l, double h) -> std::uint8_t { return h < below ? 0 : l >= above ? 1 : 2; };
  // Whole columns first, one batch of equal boxes: the centres, and the largest half extent
  // (columns of a grid differ in float rounding only; a larger box is still a conservative one).
  // Then the segments of the columns that may cross: a proven column's segments share its side.
  const std::size_t columns = std::size_t(n) * n;
  for (auto* v : {&t.cx, &t.cy, &t.cz, &t.lo, &t.hi}) v->resize(columns * std::max(nx, 1u));
  glm::dvec3 half(0.5 * size.x, 0.0, 0.0);
  for (std::uint32_t j = 0; j < n; ++j) {
    half.y = std::max(half.y, 0.5 * (double(y[j + 1]) - double(y[j])));
    half.z = std::max(half.z, 0.5 * (double(z[j + 1]) - double(z[j])));
  }
  for (std::uint32_t k = 0; k < n; ++k)
    for (std::uint32_t j = 0; j < n; ++j) {
      const std::size_t c = j + std::size_t(n) * k;
      t.cx[c] = 0.5 * (lo.x + hi.x);
      t.cy[c] = 0.5 * (double(y[j]) + double(y[j + 1]));
      t.cz[c] = 0.5 * (double(z[k]) + double(z[k + 1]));
    }
  t.bounds(columns, t.cx.data(), t.cy.data(), t.cz.data(), half, t.lo.data(), t.hi.data());
  t.crossing.clear();
  for (std::size_t c = 0; c < columns; ++c) {
    const std::uint8_t side = sideOf(t.lo[c], t.hi[c]);
    for (std::uint32_t i = 0; i < nx; ++i) sides[i + nx * c] = side;
    if (side == 2 && nx > 1) t.crossing.push_back(c);
  }
  if (t.crossing.empty()) return;
  half.x = 0.0;
  for (std::uint32_t i = 0; i < nx; ++i) half.x = std::max(half.x, 0.5 * (double(x[i + 1]) - double(x[i])));
  std::size_t b = 0;
  for (const std::size_t c : t.crossing) {
    const std::size_t j = c % n, k = c / n;
    for (std::uint32_t i = 0; i < nx; ++i, ++b) {
      t.cx[b] = 0.5 * (double(x[i]) + double(x[i + 1]));
      t.cy[b] = 0.5 * (double(y[j]) + double(y[j + 1]));
      t.cz[b] = 0.5 * (double(z[k]) + double(z[k + 1]));
    }
  }
  t.bounds(b, t.cx.data(), t.cy.data(), t.cz.data(), half, t.lo.data(), t.hi.data());
  b = 0;
  for (const std::size_t c : t.crossing)
    for (std::uint32_t i = 0; i < nx; ++i, ++b) sides[i + nx * c] = sideOf(t.lo[b], t.hi[b]);
}

}  // namespace blobvk::cpu
