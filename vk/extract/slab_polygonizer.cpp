#include "blobvk/vk/extract/slab_polygonizer.h"

#include "blobvk/vk/device/error.h"
#include "blobvk/vk/eval/evaluator_choice.h"
#include "blobvk/vk/eval/field.h"
#include "blobvk/vk/extract/case_table.h"
#include "blobvk/vk/extract/scan.h"

#include <algorithm>
#include <optional>
#include <array>
#include <vector>

namespace blobvk::vk {
namespace {

}  // namespace

// shaders/vertex_emit.glsl's push constants.
struct SlabPolygonizer::VertexPush {
  float origin[3], cell;
  std::uint32_t nx, ny, ownedPoints, k0, codeLength, refineSteps, attributes;
  float normalStep;
  std::uint32_t vertexBase;
  std::uint32_t tileI0 = 0, tileNx = 0, tileJ0 = 0, tileNy = 0, tileLayer0 = 0, rowBase = 0, rows = 0, tileIndex = 0;
  std::uint32_t vertexCapacity = 0;
};

SlabPolygonizer::VertexPush SlabPolygonizer::vertexPush(const SlabPlan& p, std::uint32_t vertexBase,
                                                        std::uint32_t vertexCapacity) const {
  const auto pts = grid_.points();
  VertexPush push{{grid_.origin.x, grid_.origin.y, grid_.origin.z}, grid_.cellSize, std::uint32_t(pts.x), std::uint32_t(pts.y),
                  std::uint32_t(p.ownedPoints), p.k0, program_.codeLength, std::uint32_t(std::max(options_.refineSteps, 0)),
                  (options_.normals ? 1u : 0u) | (options_.colours ? 2u : 0u), options_.normalStep, vertexBase};
  push.vertexCapacity = vertexCapacity;
  return push;
}

void SlabPolygonizer::recordEmitLimits(Recorder& rec, const SlabOutputs& out) {
  const KernelPtr k = device_.kernel("emit_limits", {});
  const std::uint32_t push[2] = {out.vertexCapacity, out.triangleCapacity};
  const BufferRange bind[1] = {args_};
  rec.dispatch(*k, bind, push, sizeof(push), 1);
  // The vertex pass reads its dispatch from these arguments: writes -> indirect reads.
  rec.computeBarrier();
}

EmitOverflow SlabPolygonizer::readOverflow() const {
  std::uint32_t bits = 0;
  device_.download(args_, &bits, 4, kOverflowWord * 4);
  EmitOverflow o;
  o.vertices = (bits & 1u) != 0;
  o.triangles = (bits & 2u) != 0;
  return o;
}

void SlabPolygonizer::recordTiledVertices(Recorder& rec, const SlabPlan& p, std::uint32_t vertexBase,
                                          const SlabOutputs& out) {
  const auto pts = grid_.points();
  const std::uint32_t nx = std::uint32_t(pts.x), ny = std::uint32_t(pts.y), wg = options_.workgroupSize;
  const std::uint32_t classified = nx * ny * (p.cellLayers + 1);
  const std::uint32_t ownedLast = p.k0 + p.cellLayers - (p.last ? 0 : 1);  // last owned point layer
  // The tiles' rows within this slab's owned layers, in tile order.
  struct TileRows { std::uint32_t tile, i0, nxT, j0, nyT, layer0, rows, rowBase; };
  std::vector<TileRows> tiles;
  std::uint32_t totalRows = 0;
  const auto& plan = fieldPass_->tiles();
  for (std::uint32_t t = 0; t < plan.size(); ++t) {
    const FieldTile& f = plan[t];
    const std::uint32_t kLo = std::max(p.k0, f.first[2]), kHi = std::min(ownedLast, f.last[2]);
    if (kLo > kHi) continue;
    const std::uint32_t nyT = f.last[1] - f.first[1] + 1;
    tiles.push_back({t, f.first[0], f.last[0] - f.first[0] + 1, f.first[1], nyT, kLo - p.k0, nyT * (kHi - kLo + 1), totalRows});
    totalRows += tiles.back().rows;
  }
  if (totalRows == 0) return;
  const std::array<std::uint32_t, 1> spec{wg};
  {
    const KernelPtr k = device_.kernel("tile_rows", spec);
    const BufferRange bind[3] = {vertexOffsets_, totals_, rowScan_};
    for (const TileRows& t : tiles) {
      const std::uint32_t push[10] = {nx, ny, t.i0, t.nxT, t.j0, t.nyT, t.layer0, t.rows, t.rowBase, classified};
      const Groups g = groupsFor(t.rows, wg);
      rec.dispatch(*k, bind, push, sizeof(push), g.x, g.y);
    }
  }
  rec.computeBarrier();
  // Words 0 .. pointScratch_ of the scratch held the vertex scan's partial sums, dead by now.
  recordExclusiveScan(rec, rowScan_.handle(), 0, totalRows, scratch_.handle(), 0, totals_.handle(), 2);
  rec.computeBarrier();
  {
    const KernelPtr k = device_.kernel("tile_args", {});
    const BufferRange bind[3] = {rowScan_, totals_, tileArgs_};
    for (const TileRows& t : tiles) {
      const std::uint32_t push[5] = {t.rowBase, t.rows, totalRows, t.tile, wg};
      rec.dispatch(*k, bind, push, sizeof(push), 1);
    }
  }
  rec.computeBarrier();
  const auto pb = program_.bindings();
  const BufferRange bind[14] = {pb[0], pb[1], pb[2], pb[3], pb[4], field_, flags_, vertexOffsets_,
                                out.positions, out.normals, out.colours, out.keys, tileArgs_, rowScan_};
  for (const TileRows& t : tiles) {
    VertexPush push = vertexPush(p, vertexBase, out.vertexCapacity);
    push.tileI0 = t.i0;
    push.tileNx = t.nxT;
    push.tileJ0 = t.j0;
    push.tileNy = t.nyT;
    push.tileLayer0 = t.layer0;
    push.rowBase = t.rowBase;
    push.rows = t.rows;
    push.tileIndex = t.tile;
    rec.dispatchIndirect(*vertexTileKernels_[t.tile], bind, &push, sizeof(push), tileArgs_, VkDeviceSize(t.tile) * 16);
  }
}

SlabPolygonizer::SlabPolygonizer(Device& device, const blobtree::Program& program,
                                 const blobtree::GridSpec& grid,
                                 const GpuPolygonizeOptions& options)
    : device_(device), grid_(grid), options_(options) {
  const auto pts = grid.points();
  if (grid.cells.x < 1 || grid.cells.y < 1 || grid.cells.z < 1) {
    throw VulkanError("GPU polygonizer: the grid has no cells");
  }
  FieldTilingOptions tiling;
  tiling.maxTiles = options.maxFieldTiles;
  std::optional<CodegenOptions> codegen;
  if (options.codegen) codegen = *options.codegen;
  if (options_.traversal == Traversal::Auto) {
    EvaluatorJob job;
    job.vertexPass = true;
    job.refineSteps = options.refineSteps;
    job.repeats = std::max<std::uint32_t>(options.expectedRuns, 1);
    job.tiling = tiling;
    job.workgroupSize = options.workgroupSize;
    codegen = options.codegen ? *options.codegen : defaultCodegenOptions(device);
    const EvaluatorEstimate e = chooseEvaluator(device, program, grid, job, *codegen).chosen;
    options_.traversal = e.traversal;
    codegen->gradient = e.vertexGradient;
    tiling.maxTiles = e.fieldKernels;
    tiling.minPointsForLargePrograms = 0;  // the model weighed the tiles' build time
  }
  program_ = uploadProgram(device, program, options_.traversal, codegen ? &*codegen : nullptr);
  fieldPass_ = std::make_unique<FieldPass>(device, program, program_, options_.traversal, options.workgroupSize,
                                           grid, tiling);
  // Vertex kernels inline the evaluator several times (refinement, six normal samples, colour):
  // for a program too large to specialise whole, even its tiles' kernels took seconds each to
  // build on lavapipe, so its vertices keep the one interpreter pass.
  if (options.tiledVertexPass && fieldPass_->tileCount() > 1 && program_.specialised) {
    // A vertex of point p's edges is evaluated between p and p + one cell (refinement) and a
    // normal step around that: the tile's region grown by a cell and the step.
    std::uint64_t rows = 1;
    for (const FieldTile& t : fieldPass_->tiles()) {
      PointRegion r = t.region;
      for (int a = 0; a < 3; ++a) {
        r.lo[a] -= options.normalStep;
        r.hi[a] += grid.cellSize + options.normalStep;
      }
      if (specialiseTile(program, r, program_.codegen.loops)) {
        CodegenOptions c = program_.codegen;
        c.region = r;
        vertexTileKernels_.push_back(
            specialisedKernel(device, program, program_.fingerprint, c, "vertices_tiled", options.workgroupSize));
      } else {
        vertexTileKernels_.push_back(
            evaluatorKernel(device, program_, "vertices_tiled", options.workgroupSize, options_.traversal));
      }
      rows += std::uint64_t(t.last[1] - t.first[1] + 1) * (t.last[2] - t.first[2] + 1);
    }
    rowScan_ = device.createBuffer(rows * 4);
    tileArgs_ = device.createBuffer(fieldPass_->tileCount() * 16, MemoryUse::DeviceLocal,
                                    VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT);
  }
  const auto& words = packedCaseTable();
  cases_ = device.createBuffer(words.size() * 4);
  device.upload(cases_, words.data(), words.size() * 4);

  // A slab of C cell layers needs C + 2 field layers (the top one for the +z edges of the
  // slab's top point layer, whose offsets the triangles need).
  const std::uint32_t layers = layersPerBrick(device, grid, options.maxBrickBytes, 4);
  slabCells_ = std::max<std::uint32_t>(1, std::min<std::uint32_t>(layers > 2 ? layers - 2 : 1,
                                                                    std::uint32_t(grid.cells.z)));
  slabs_ = (std::uint32_t(grid.cells.z) + slabCells_ - 1) / slabCells_;
  const std::uint64_t layer = std::uint64_t(pts.x) * std::uint64_t(pts.y);
  const std::uint64_t points = layer * (slabCells_ + 1);
  const std::uint64_t cells = std::uint64_t(grid.cells.x) * std::uint64_t(grid.cells.y) * slabCells_;
  field_ = device.createBuffer(layer * std::min<std::uint64_t>(slabCells_ + 2, pts.z) * 4);
  flags_ = device.createBuffer(points * 4);
  vertexOffsets_ = device.createBuffer(points * 4);
  triOffsets_ = device.createBuffer(cells * 4);
  pointScratch_ = std::uint32_t(scanScratchWords(points));
  scratch_ = device.createBuffer((pointScratch_ + scanScratchWords(cells) + 1) * 4);
  totals_ = device.createBuffer(16);
  args_ = device.createBuffer(kDrawArgsWords * 4, MemoryUse::DeviceLocal, VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT);
}

SlabPlan SlabPolygonizer::plan(std::uint32_t slab) const {
  SlabPlan p;
  p.k0 = slab * slabCells_;
  p.cellLayers = std::min<std::uint32_t>(slabCells_, std::uint32_t(grid_.cells.z) - p.k0);
  p.last = p.k0 + p.cellLayers == std::uint32_t(grid_.cells.z);
  const auto pts = grid_.points();
  const std::uint64_t layer = std::uint64_t(pts.x) * std::uint64_t(pts.y);
  p.ownedPoints = layer * (p.cellLayers + (p.last ? 1 : 0));
  p.cells = std::uint64_t(grid_.cells.x) * std::uint64_t(grid_.cells.y) * p.cellLayers;
  return p;
}

void SlabPolygonizer::recordClassify(Recorder& rec, std::uint32_t slab, std::uint32_t vertexBase,
                                     std::uint32_t triangleBase) {
  const SlabPlan p = plan(slab);
  const auto pts = grid_.points();
  const std::uint32_t nx = std::uint32_t(pts.x), ny = std::uint32_t(pts.y);
  const std::uint32_t wg = options_.workgroupSize;
  const std::array<std::uint32_t, 1> gridSpec{gridGroupRows(wg)};
  // Field layers: the slab's point layers k0 .. k0 + C, plus one above unless at the top.
  const std::uint32_t fieldLayers = p.cellLayers + 1 + (p.last ? 0 : 1);
  const std::uint32_t classified = nx * ny * (p.cellLayers + 1);
  fieldPass_->record(rec, p.k0, fieldLayers, field_);
  rec.computeBarrier();
  {
    const KernelPtr k = device_.kernel("edge_flags", gridSpec);
    const std::uint32_t push[6] = {nx, ny, std::uint32_t(grid_.cells.x), std::uint32_t(grid_.cells.y),
                                   std::uint32_t(grid_.cells.z), p.k0};
    const BufferRange bind[3] = {field_, flags_, vertexOffsets_};
    const Groups3 g = gridGroups(nx, ny, p.cellLayers + 1, wg);
    rec.dispatch(*k, bind, push, sizeof(push), g.x, g.y, g.z);
  }
  {
    const KernelPtr k = device_.kernel("cell_count", gridSpec);
    const std::uint32_t push[4] = {nx, ny, std::uint32_t(grid_.cells.x), std::uint32_t(grid_.cells.y)};
    const BufferRange bind[3] = {field_, cases_, triOffsets_};
    const Groups3 g = gridGroups(std::uint32_t(grid_.cells.x), std::uint32_t(grid_.cells.y), p.cellLayers, wg);
    rec.dispatch(*k, bind, push, sizeof(push), g.x, g.y, g.z);
  }
  rec.computeBarrier();
  recordExclusiveScan(rec, vertexOffsets_.handle(), 0, classified, scratch_.handle(), 0,
                      totals_.handle(), 0);
  // The two scans use disjoint words of the scratch and of the totals, but the buffers are bound
  // whole and synchronisation validation tracks hazards per bound range: without this barrier the
  // second scan's writes race (as far as the layer can tell) with the first one's reads.
  rec.computeBarrier();
  recordExclusiveScan(rec, triOffsets_.handle(), 0, std::uint32_t(p.cells), scratch_.handle(),
                      pointScratch_, totals_.handle(), 1);
  rec.computeBarrier();
  {
    const KernelPtr k = device_.kernel("draw_args", {});
    const std::uint32_t push[5] = {std::uint32_t(p.ownedPoints), p.last ? 1u : 0u, vertexBase,
                                   triangleBase, wg};
    const BufferRange bind[3] = {vertexOffsets_, totals_, args_};
    rec.dispatch(*k, bind, push, sizeof(push), 1);
  }
  rec.computeBarrier();
}

void SlabPolygonizer::recordEmit(Recorder& rec, std::uint32_t slab, std::uint32_t vertexBase,
                                 const SlabOutputs& out) {
  const SlabPlan p = plan(slab);
  const auto pts = grid_.points();
  const std::uint32_t nx = std::uint32_t(pts.x), ny = std::uint32_t(pts.y);
  const std::uint32_t wg = options_.workgroupSize;
  recordEmitLimits(rec, out);
  if (!vertexTileKernels_.empty()) {
    recordTiledVertices(rec, p, vertexBase, out);
  } else {
    // One lane per vertex (indirect: the count is on the device), so every lane of a SIMD
    // group evaluates; a lane per grid point would leave most lanes idle and, on llvmpipe, pay
    // for every masked-off evaluation too.
    const KernelPtr k = evaluatorKernel(device_, program_, "vertices", wg, options_.traversal);
    const VertexPush push = vertexPush(p, vertexBase, out.vertexCapacity);
    const auto pb = program_.bindings();
    const BufferRange bind[13] = {pb[0], pb[1], pb[2], pb[3], pb[4], field_, flags_, vertexOffsets_,
                                  out.positions, out.normals, out.colours, out.keys, args_};
    rec.dispatchIndirect(*k, bind, &push, sizeof(push), args_, 7 * 4);
  }
  {
    const std::array<std::uint32_t, 1> gridSpec{gridGroupRows(wg)};
    const KernelPtr k = device_.kernel("triangles", gridSpec);
    const std::uint32_t push[6] = {nx, ny, std::uint32_t(grid_.cells.x), std::uint32_t(grid_.cells.y), vertexBase,
                                   out.triangleCapacity};
    const BufferRange bind[6] = {field_, cases_, flags_, vertexOffsets_, triOffsets_, out.indices};
    const Groups3 g = gridGroups(std::uint32_t(grid_.cells.x), std::uint32_t(grid_.cells.y), p.cellLayers, wg);
    rec.dispatch(*k, bind, push, sizeof(push), g.x, g.y, g.z);
  }
  rec.computeBarrier();
}

}  // namespace blobvk::vk
