#include "blobvk/fem/voxel_mesher.h"

#include "blobvk/fem/tet_utils.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <tbb/parallel_for.h>

namespace blobvk::fem {
namespace {

// Corner c of a cell: bit 0 = x (L/R), bit 1 = y (B/T), bit 2 = z (N/F).
enum Corner { LBN = 0, RBN = 1, LTN = 2, RTN = 3, LBF = 4, RBF = 5, LTF = 6, RTF = 7 };
// thesis.md §6.6 (Tetrahedralizer.cl): shares the diagonals LTN-LBF/RTN-RBF (x faces),
// RBN-LBF/RTN-LTF (y faces) and LTN-RBN/LTF-RBF (z faces), so the grid conforms.
constexpr int kSixTets[6][4] = {{LBN, LTN, RBN, LBF}, {RTN, LTN, LBF, RBN}, {RTN, LTN, LTF, LBF},
                                {RTN, RBN, LBF, RBF}, {RTN, LBF, LTF, RBF}, {RTN, LTF, RTF, RBF}};

// cellInside(i,j,k) decides; corners are grid points at origin + spacing * index.
mesh::TetMesh buildFromCells(const mesh::Double3& origin, double h, int cx, int cy, int cz,
                             const std::vector<unsigned char>& keep) {
  const long px = cx + 1, py = cy + 1, pz = cz + 1;
  std::vector<std::uint32_t> nodeOf(std::size_t(px * py * pz), UINT32_MAX);
  mesh::TetMesh out;
  auto node = [&](long i, long j, long k) {
    auto& slot = nodeOf[std::size_t((k * py + j) * px + i)];
    if (slot == UINT32_MAX) {
      slot = std::uint32_t(out.positions.size());
      out.positions.push_back({origin.x + h * double(i), origin.y + h * double(j), origin.z + h * double(k)});
    }
    return slot;
  };
  for (long k = 0; k < cz; ++k)
    for (long j = 0; j < cy; ++j)
      for (long i = 0; i < cx; ++i) {
        if (!keep[std::size_t((k * cy + j) * cx + i)]) continue;
        std::uint32_t c[8];
        for (int b = 0; b < 8; ++b) c[b] = node(i + (b & 1), j + ((b >> 1) & 1), k + ((b >> 2) & 1));
        for (const auto& t : kSixTets) out.tets.push_back({c[t[0]], c[t[1]], c[t[2]], c[t[3]]});
      }
  if (out.tets.empty()) throw std::invalid_argument("voxel mesher: no cell is inside the surface");
  out.restPositions = out.positions;
  orientTets(out);
  out.boundaryFaces = findBoundaryFaces(out);
  return out;
}

}  // namespace

mesh::TetMesh voxelTetrahedralize(const ScalarField& field, const VoxelMesherSettings& s) {
  if (!(s.cellSize > 0)) throw std::invalid_argument("voxel mesher: cellSize must be > 0");
  const double ex = s.boundsMax.x - s.boundsMin.x, ey = s.boundsMax.y - s.boundsMin.y, ez = s.boundsMax.z - s.boundsMin.z;
  if (!(ex > 0 && ey > 0 && ez > 0)) throw std::invalid_argument("voxel mesher: empty bounds");
  // Cells per axis in double first: a tiny cellSize would overflow an int (and pass the check).
  const double fx = std::max(1.0, std::ceil(ex / s.cellSize - 1e-9)), fy = std::max(1.0, std::ceil(ey / s.cellSize - 1e-9)),
               fz = std::max(1.0, std::ceil(ez / s.cellSize - 1e-9));
  if (!(fx * fy * fz <= 5e7)) throw std::invalid_argument("voxel mesher: more than 5e7 cells; raise cellSize");
  const int cx = int(fx), cy = int(fy), cz = int(fz);
  const double h = s.cellSize;
  const long px = cx + 1, py = cy + 1;
  std::vector<unsigned char> inside(std::size_t(px * py * (cz + 1)));
  tbb::parallel_for(0, cz + 1, [&](int k) {
    for (int j = 0; j <= cy; ++j)
      for (int i = 0; i <= cx; ++i)
        inside[std::size_t((k * py + j) * px + i)] =
            field(s.boundsMin.x + h * i, s.boundsMin.y + h * j, s.boundsMin.z + h * k) >= s.iso;
  });
  std::vector<unsigned char> keep(std::size_t(cx) * cy * cz);
  tbb::parallel_for(0, cz, [&](int k) {
    for (int j = 0; j < cy; ++j)
      for (int i = 0; i < cx; ++i) {
        bool in = field(s.boundsMin.x + h * (i + 0.5), s.boundsMin.y + h * (j + 0.5), s.boundsMin.z + h * (k + 0.5)) >= s.iso;
        for (int b = 0; b < 8 && !in; ++b)
          in = inside[std::size_t(((k + ((b >> 2) & 1)) * py + j + ((b >> 1) & 1)) * px + i + (b & 1))];
        keep[std::size_t((k * cy + j) * cx + i)] = in;
      }
  });
  const std::size_t tets = 6 * std::size_t(std::count(keep.begin(), keep.end(), 1));
  if (tets > s.maxTets) {
    char text[160];
    std::snprintf(text, sizeof text, "voxel mesher: cells of %.3g make %zu tets, more than the limit of %zu; raise cellSize",
                  s.cellSize, tets, s.maxTets);
    throw std::invalid_argument(text);
  }
  return buildFromCells(s.boundsMin, h, cx, cy, cz, keep);
}

mesh::TetMesh voxelTetrahedralize(const SampledGrid& g, float iso) {
  if (g.nx < 2 || g.ny < 2 || g.nz < 2) throw std::invalid_argument("voxel mesher: grid needs >= 2 points per axis");
  if (g.values.size() != std::size_t(g.nx) * g.ny * g.nz) throw std::invalid_argument("voxel mesher: grid value count mismatch");
  if (!(g.spacing > 0)) throw std::invalid_argument("voxel mesher: spacing must be > 0");
  const int cx = g.nx - 1, cy = g.ny - 1, cz = g.nz - 1;
  std::vector<unsigned char> keep(std::size_t(cx) * cy * cz);
  for (int k = 0; k < cz; ++k)
    for (int j = 0; j < cy; ++j)
      for (int i = 0; i < cx; ++i) {
        double sum = 0;
        bool in = false;
        for (int b = 0; b < 8; ++b) {
          const float v = g.values[std::size_t(((k + ((b >> 2) & 1)) * g.ny + j + ((b >> 1) & 1)) * g.nx + i + (b & 1))];
          sum += v;
          in = in || v >= iso;
        }
        keep[std::size_t((k * cy + j) * cx + i)] = in || sum / 8 >= iso;
      }
  return buildFromCells(g.origin, g.spacing, cx, cy, cz, keep);
}

}  // namespace blobvk::fem
