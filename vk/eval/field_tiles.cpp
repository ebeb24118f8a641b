#include "blobvk/vk/eval/field_tiles.h"

#include "blobvk/vk/eval/host_memo.h"

#include <algorithm>

namespace blobvk::vk {
namespace {

FieldTile makeTile(const blobtree::Program& program, const blobtree::GridSpec& grid,
                   const std::array<std::uint32_t, 3>& first, const std::array<std::uint32_t, 3>& last) {
  FieldTile t;
  t.first = first;
  t.last = last;
  t.region = regionOfPoints(grid, first, last);
  t.cost = prunedEvaluationCost(program, t.region);
  return t;
}

double work(const FieldTile& t) { return double(t.points()) * double(t.cost); }

// Of the splits of `t` along any axis at an eighth of its extent that `accept` takes, the one that
// removes the most work (the first best wins ties), and that work; false when there is none.
template <class Accept>
bool bestSplit(const blobtree::Program& program, const blobtree::GridSpec& grid, const FieldTile& t,
               std::uint32_t minExtent, const Accept& accept, FieldTile& low, FieldTile& high, double& bestGain) {
  bool found = false;
  bestGain = 0.0;
  for (int axis = 0; axis < 3; ++axis) {
    const std::uint32_t extent = t.last[std::size_t(axis)] - t.first[std::size_t(axis)] + 1;
    if (extent < 2 * minExtent) continue;
    for (std::uint32_t eighth = 1; eighth <= 7; ++eighth) {
      const std::uint32_t lowCount = std::clamp(extent * eighth / 8, minExtent, extent - minExtent);
      auto lowLast = t.last, highFirst = t.first;
      lowLast[std::size_t(axis)] = t.first[std::size_t(axis)] + lowCount - 1;
      highFirst[std::size_t(axis)] = t.first[std::size_t(axis)] + lowCount;
      FieldTile l = makeTile(program, grid, t.first, lowLast);
      FieldTile h = makeTile(program, grid, highFirst, t.last);
      const double gain = work(t) - work(l) - work(h);
      if ((!found || gain > bestGain) && accept(l, h)) {
        found = true;
        bestGain = gain;
        low = l;
        high = h;
      }
    }
  }
  return found;
}

bool anySplit(const FieldTile&, const FieldTile&) { return true; }

// FieldTilingOptions::maxTilesForLoopedCode: the looped tile with the most work split, until no
// tile loops or the cap is reached. A split must shed code from both halves (each keeps at most
// kShedShare of the tile's instructions), so that a dense knot of primitives, which no split
// unrolls, is left looped rather than cut into kernels that all loop.
void splitLoopedTiles(const blobtree::Program& program, const blobtree::GridSpec& grid,
                      const FieldTilingOptions& options, std::vector<FieldTile>& tiles) {
  constexpr double kShedShare = 0.9;
  const std::uint32_t minExtent = std::max<std::uint32_t>(options.minExtent, 1);
  // The region the tile's kernel evaluates, and whether its code there loops.
  const auto pts = grid.points();
  const std::array<std::uint32_t, 3> lastPoint{std::uint32_t(pts.x - 1), std::uint32_t(pts.y - 1), std::uint32_t(pts.z - 1)};
  auto kernelRegion = [&](const FieldTile& t) {
    auto last = t.last;
    for (std::size_t a = 0; a < 3; ++a) last[a] = std::min(last[a] + options.kernelReach, lastPoint[a]);
    return regionOfPoints(grid, t.first, last);
  };
  auto loops = [&](const FieldTile& t) { return specialisedCodeLoops(program, kernelRegion(t), options.loops); };
  std::vector<char> looped;  // per tile: its code loops and a split may still shed some
  for (const FieldTile& t : tiles) looped.push_back(loops(t));
  while (tiles.size() < options.maxTilesForLoopedCode) {
    std::size_t pick = tiles.size();
    for (std::size_t i = 0; i < tiles.size(); ++i)
      if (looped[i] && (pick == tiles.size() || work(tiles[i]) > work(tiles[pick]))) pick = i;
    if (pick == tiles.size()) break;
    FieldTile low, high;
    const double limit = kShedShare * double(prunedInstructionCount(program, kernelRegion(tiles[pick])));
    auto sheds = [&](const FieldTile& l, const FieldTile& h) {
      return double(prunedInstructionCount(program, kernelRegion(l))) <= limit &&
             double(prunedInstructionCount(program, kernelRegion(h))) <= limit;
    };
    double gain = 0.0;
    if (!bestSplit(program, grid, tiles[pick], minExtent, sheds, low, high, gain)) {
      looped[pick] = 0;  // no split sheds code: the tile keeps its looped code
      continue;
    }
    tiles[pick] = low;
    looped[pick] = loops(low);
    tiles.insert(tiles.begin() + std::ptrdiff_t(pick) + 1, high);
    looped.insert(looped.begin() + std::ptrdiff_t(pick) + 1, loops(high));
  }
}

}  // namespace

PointRegion regionOfPoints(const blobtree::GridSpec& grid, const std::array<std::uint32_t, 3>& first,
                           const std::array<std::uint32_t, 3>& last) {
  const glm::vec3 a = grid.point(int(first[0]), int(first[1]), int(first[2]));
  const glm::vec3 b = grid.point(int(last[0]), int(last[1]), int(last[2]));
  const float pad = 0.01f * grid.cellSize;
  PointRegion r;
  r.valid = true;
  for (int i = 0; i < 3; ++i) {
    r.lo[i] = std::min(a[i], b[i]) - pad;
    r.hi[i] = std::max(a[i], b[i]) + pad;
  }
  return r;
}

bool specialiseTile(const blobtree::Program& program, const PointRegion& region, const LoopOptions& loops) {
  if (!canSpecialise(program, region, loops)) return false;
  return canSpecialise(program, {}, loops) || specialisedCodeSize(program, region, loops) <= kMaxTileInstructions;
}

std::vector<char> specialiseTiles(const blobtree::Program& program, std::uint64_t fingerprint,
                                  std::span<const PointRegion> regions, const LoopOptions& loops) {
  static HostMemo<std::vector<char>> memo;
  MemoKey key;
  addLoopOptions(key.add(fingerprint ? fingerprint : programFingerprint(program)), loops);
  for (const PointRegion& r : regions) key.add(r.valid).add(r.lo).add(r.hi);
  auto compute = [&] {
    std::vector<char> own(regions.size());
    for (std::size_t t = 0; t < regions.size(); ++t) own[t] = specialiseTile(program, regions[t], loops);
    return own;
  };
  std::vector<char> own = memo.get(key, compute);
  return own.size() == regions.size() ? own : compute();  // a 64-bit key collision: never index past it
}

std::vector<FieldTile> planFieldTiles(const blobtree::Program& program, const blobtree::GridSpec& grid,
                                      const FieldTilingOptions& options) {
  const auto pts = grid.points();
  std::vector<FieldTile> tiles;
  if (pts.x < 1 || pts.y < 1 || pts.z < 1) return tiles;
  tiles.push_back(makeTile(program, grid, {0, 0, 0},
                           {std::uint32_t(pts.x - 1), std::uint32_t(pts.y - 1), std::uint32_t(pts.z - 1)}));
  const std::uint32_t minExtent = std::max<std::uint32_t>(options.minExtent, 1);
  while (tiles.size() < std::max<std::uint32_t>(options.maxTiles, 1)) {
    double total = 0.0;
    for (const auto& t : tiles) total += work(t);
    // The best split over every tile, axis and position (the first best wins ties).
    double bestGain = 0.0;
    std::size_t bestTile = 0;
    FieldTile bestLow, bestHigh;
    for (std::size_t ti = 0; ti < tiles.size(); ++ti) {
      FieldTile low, high;
      double gain = 0.0;
      if (bestSplit(program, grid, tiles[ti], minExtent, anySplit, low, high, gain) && gain > bestGain) {
        bestGain = gain;
        bestTile = ti;
        bestLow = low;
        bestHigh = high;
      }
    }
    if (bestGain <= options.minGain * total) break;
    tiles[bestTile] = bestLow;
    tiles.insert(tiles.begin() + std::ptrdiff_t(bestTile) + 1, bestHigh);
  }
  if (options.maxTilesForLoopedCode > tiles.size() && options.loops.minProgramInstructions > 0)
    splitLoopedTiles(program, grid, options, tiles);
  return tiles;
}

}  // namespace blobvk::vk
