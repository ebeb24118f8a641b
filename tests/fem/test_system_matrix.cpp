// The solver's assembled matrix (fem/system_matrix.h) against two oracles: the matrix-free
// per-tet product it replaces, and a fresh build of the same tets after incremental row edits.
#include "blobvk/fem/elements.h"
#include "blobvk/fem/system_matrix.h"
#include "tests/fem/cut_changes.h"
#include "tests/fem/test_helpers.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

namespace blobvk::fem {
namespace {

using mesh::Double3;

// A deformed configuration: rest positions bent and stretched (non-trivial rotations).
std::vector<Double3> deformed(const std::vector<Double3>& rest) {
  std::vector<Double3> x(rest.size());
  for (std::size_t i = 0; i < rest.size(); ++i) {
    const Double3& p = rest[i];
    const double a = 0.2 + 1.5 * p.y, c = std::cos(a), s = std::sin(a);
    x[i] = {c * p.x - s * p.y, s * p.x + c * p.y, 1.05 * p.z + 0.01 * std::sin(7 * p.x)};
  }
  return x;
}

std::vector<double> testVector(std::size_t n) {
  std::vector<double> p(n);
  for (std::size_t i = 0; i < n; ++i) p[i] = std::sin(0.37 * double(i) + 0.1) + 0.5;
  return p;
}

const std::vector<Material> kMaterials = {Material{1e5, 0.45, 1000}};
constexpr double kScale = 2.8e-4;  // h^2 at 60 Hz

TEST(SystemMatrix, ProductEqualsTheMatrixFreeOperatorAndKeepsTranslationsExact) {
  const mesh::TetMesh m = test::boxMesh(0.3, 0.2, 0.2, 0.05);
  ElementSet elements;
  elements.build(m, kMaterials);
  const std::size_t n = m.nodeCount();
  std::vector<double> force(3 * n), nodeScale(n);
  for (std::size_t i = 0; i < n; ++i) nodeScale[i] = 1e-3 * (1.0 + 0.1 * double(i % 7));
  elements.computeForces(deformed(m.restPositions), 30, force.data(), nullptr);
  SystemMatrix A;
  A.buildPattern(elements.incidence(), m.tets);
  elements.assembleMatrix(A, nodeScale.data(), kScale);

  const std::vector<double> p = testVector(3 * n);
  std::vector<double> assembled(3 * n), matrixFree(3 * n);
  A.multiply(p.data(), assembled.data());
  elements.applySystem(p.data(), matrixFree.data(), nodeScale.data(), kScale);
  double diff = 0, scale = 0;
  for (std::size_t i = 0; i < 3 * n; ++i) {
    diff = std::max(diff, std::abs(assembled[i] - matrixFree[i]));
    scale = std::max(scale, std::abs(matrixFree[i]));
  }
  EXPECT_GT(scale, 0.1);          // the stiffness part dominates (not a mass-only check)
  EXPECT_LT(diff, 1e-6 * scale);  // float off-diagonal blocks: ~1e-7 relative

  // A rigid translation: K~ t = 0, so A t = nodeScale t, despite the float off-diagonals.
  std::vector<double> t(3 * n), At(3 * n);
  for (std::size_t i = 0; i < n; ++i) t[3 * i] = 1, t[3 * i + 1] = -2, t[3 * i + 2] = 0.5;
  A.multiply(t.data(), At.data());
  for (std::size_t i = 0; i < 3 * n; ++i) ASSERT_NEAR(At[i], nodeScale[i / 3] * t[i], 1e-12 * 3 * scale) << "dof " << i;
}

// Several cut-like changes, each applied to the element set and to the matrix's rows of the
// nodes they touch (rows outgrow their room and move); the product must equal, bit for bit, that
// of a matrix built from scratch on the final tets.
TEST(SystemMatrix, EditedRowsEqualAFreshBuildThroughRowMoves) {
  mesh::TetMesh m = test::boxMesh(0.2, 0.2, 0.2, 0.05);
  ElementSet elements;
  elements.build(m, kMaterials);
  SystemMatrix A;
  A.buildPattern(elements.incidence(), m.tets);
  std::size_t moves = 0;
  for (int round = 0; round < 6; ++round) {
    test::ChangeBuilder b(m);
    // Split every edge from the centre node to a neighbour: the centre's row grows each round.
    const std::uint32_t centre = 62;  // an interior node of the 5x5x5 grid
    std::vector<std::uint32_t> neighbours;
    for (const auto& tet : m.tets)
      if (std::find(tet.begin(), tet.end(), centre) != tet.end())
        for (auto v : tet)
          if (v != centre) neighbours.push_back(v);
    std::sort(neighbours.begin(), neighbours.end());
    neighbours.erase(std::unique(neighbours.begin(), neighbours.end()), neighbours.end());
    for (std::size_t k = 0; k < neighbours.size(); k += 3) b.splitEdge(centre, neighbours[k], 0.5);
    const TopologyChange c = b.build();
    std::vector<std::uint32_t> touched;
    const std::size_t oldNodes = m.nodeCount();
    for (const NodeOrigin& o : c.newNodes) {
      Double3 r{};
      for (int i = 0; i < 4; ++i)
        if (o.sources[std::size_t(i)] != kNoSource) {
          const Double3& s = m.restPositions[o.sources[std::size_t(i)]];
          const double w = o.weights[std::size_t(i)];
          r = {r.x + w * s.x, r.y + w * s.y, r.z + w * s.z};
        }
      m.restPositions.push_back(r);
      m.positions.push_back(r);
      touched.push_back(std::uint32_t(m.restPositions.size() - 1));
    }
    elements.addNodes(c.newNodes.size());
    for (std::size_t k = 0; k < c.tetSlots.size(); ++k) {
      const std::uint32_t slot = c.tetSlots[k];
      if (slot < m.tets.size()) {
        touched.insert(touched.end(), m.tets[slot].begin(), m.tets[slot].end());
        m.tets[slot] = c.tetNodes[k];
      } else {
        m.tets.push_back(c.tetNodes[k]);
      }
      touched.insert(touched.end(), c.tetNodes[k].begin(), c.tetNodes[k].end());
      elements.setTet(slot, c.tetNodes[k], m.restPositions, kMaterials[0]);
    }
    std::sort(touched.begin(), touched.end());
    touched.erase(std::unique(touched.begin(), touched.end()), touched.end());
    std::vector<std::uint32_t> startBefore(oldNodes);
    for (std::size_t v = 0; v < oldNodes; ++v) startBefore[v] = A.rowBegin(v);
    A.updateRows(elements.incidence(), m.tets, touched);
    for (std::size_t v = 0; v < oldNodes; ++v) moves += A.rowBegin(v) != startBefore[v] ? 1 : 0;
  }
  EXPECT_GT(moves, 0u);  // rows of old nodes have outgrown their room and moved

  SystemMatrix fresh;
  ElementSet freshElements;
  m.regions.clear();
  freshElements.build(m, kMaterials);
  fresh.buildPattern(freshElements.incidence(), m.tets);
  const std::size_t n = m.nodeCount();
  const std::vector<Double3> x = deformed(m.restPositions);
  std::vector<double> force(3 * n), nodeScale(n, 1e-3);
  elements.computeForces(x, 30, force.data(), nullptr);
  freshElements.computeForces(x, 30, force.data(), nullptr);
  elements.assembleMatrix(A, nodeScale.data(), kScale);
  freshElements.assembleMatrix(fresh, nodeScale.data(), kScale);
  const std::vector<double> p = testVector(3 * n);
  std::vector<double> edited(3 * n), reference(3 * n), matrixFree(3 * n);
  A.multiply(p.data(), edited.data());
  fresh.multiply(p.data(), reference.data());
  for (std::size_t i = 0; i < 3 * n; ++i) ASSERT_EQ(edited[i], reference[i]) << "dof " << i;
  for (std::size_t v = 0; v < n; ++v) ASSERT_EQ(A.rowEnd(v) - A.rowBegin(v), fresh.rowEnd(v) - fresh.rowBegin(v)) << v;
  elements.applySystem(p.data(), matrixFree.data(), nodeScale.data(), kScale);
  double diff = 0, scale = 0;
  for (std::size_t i = 0; i < 3 * n; ++i) {
    diff = std::max(diff, std::abs(edited[i] - matrixFree[i]));
    scale = std::max(scale, std::abs(matrixFree[i]));
  }
  EXPECT_LT(diff, 1e-6 * scale);
}

}  // namespace
}  // namespace blobvk::fem
