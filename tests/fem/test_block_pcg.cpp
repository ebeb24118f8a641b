// The default solver path (fem/block_pcg.h: CG on the assembled SystemMatrix, two fused passes per
// iteration by Chronopoulos-Gear's recurrence, with the two-level correction of
// fem/coarse_correction.h) against a dense direct solve of the same matrix, and against the
// textbook PCG (fem/pcg.h) with the same preconditioner: in exact arithmetic both produce the same
// iterates, so they must stop after (nearly) the same number of iterations. The coarse correction
// must reach the same solution in fewer iterations, alone and inside a simulation step.
#include "blobvk/fem/block_pcg.h"
#include "blobvk/fem/coarse_correction.h"
#include "blobvk/fem/elements.h"
#include "blobvk/fem/pcg.h"
#include "blobvk/fem/simulation.h"
#include "blobvk/fem/system_matrix.h"
#include "test_helpers.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <random>

#include <Eigen/Dense>

namespace blobvk::fem {
namespace {

struct AssembledSystem {
  mesh::TetMesh mesh = test::boxMesh(0.2, 0.1, 0.1, 0.025);
  ElementSet elements;
  SystemMatrix matrix;
  std::vector<unsigned char> freeDof;
  std::vector<double> b;
  Eigen::MatrixXd full;   // the whole matrix, column by column from products
  Eigen::MatrixXd dense;  // the matrix on free DOFs, identity rows on fixed ones

  AssembledSystem() {
    // Rotated and noisy positions: rotations and warped stiffness are not trivial.
    std::mt19937 random(11);
    std::uniform_real_distribution<double> noise(-0.003, 0.003);
    const Eigen::Matrix3d R = Eigen::AngleAxisd(0.5, Eigen::Vector3d(1, 2, 0.5).normalized()).toRotationMatrix();
    for (auto& p : mesh.positions) {
      const Eigen::Vector3d q = R * Eigen::Vector3d(p.x, p.y, p.z);
      p = {q.x() + noise(random), q.y() + noise(random), q.z() + noise(random)};
    }
    elements.build(mesh, {Material{1e5, 0.45, 1000}});
    const std::size_t n = mesh.nodeCount(), dofs = 3 * n;
    std::vector<double> force(dofs), nodeScale(n);
    elements.computeForces(mesh.positions, 30, force.data(), nullptr);
    const std::vector<double> mass = elements.lumpedMass();
    for (std::size_t i = 0; i < n; ++i) nodeScale[i] = 1.2 * mass[i];
    matrix.buildPattern(elements.incidence(), mesh.tets);
    elements.assembleMatrix(matrix, nodeScale.data(), 2.8e-4);  // h^2 at 60 Hz: stiffness-dominated
    freeDof.assign(dofs, 1);
    for (std::size_t i = 0; i < n; ++i)
      if (mesh.restPositions[i].x < 1e-9) freeDof[3 * i] = freeDof[3 * i + 1] = freeDof[3 * i + 2] = 0;
    b.resize(dofs);
    for (std::size_t i = 0; i < dofs; ++i) b[i] = freeDof[i] ? 0.01 * force[i] + 1e-3 * std::sin(0.7 * double(i)) : 0.0;
    full.resize(Eigen::Index(dofs), Eigen::Index(dofs));
    dense.resize(Eigen::Index(dofs), Eigen::Index(dofs));
    std::vector<double> e(dofs, 0.0), column(dofs);
    for (std::size_t j = 0; j < dofs; ++j) {
      e[j] = 1;
      matrix.multiply(e.data(), column.data());
      e[j] = 0;
      for (std::size_t i = 0; i < dofs; ++i) full(Eigen::Index(i), Eigen::Index(j)) = column[i];
      for (std::size_t i = 0; i < dofs; ++i)
        dense(Eigen::Index(i), Eigen::Index(j)) = freeDof[i] && freeDof[j] ? column[i] : double(i == j);
    }
  }

  // P^-1 per node: the inverse 3x3 diagonal blocks (stride 9) or the inverse diagonal (stride 3)
  // of the free DOFs, computed here with Eigen; 0 on fixed DOFs.
  std::vector<double> inverse(int stride) const {
    const std::size_t n = mesh.nodeCount();
    std::vector<double> out(std::size_t(stride) * n, 0.0);
    for (std::size_t v = 0; v < n; ++v) {
      const Eigen::Matrix3d block = dense.block<3, 3>(Eigen::Index(3 * v), Eigen::Index(3 * v));
      const Eigen::Matrix3d inv = stride == 9 ? Eigen::Matrix3d(block.inverse())
                                              : Eigen::Matrix3d(block.diagonal().cwiseInverse().asDiagonal());
      for (int a = 0; a < 3; ++a) {
        if (!freeDof[3 * v + std::size_t(a)]) continue;
        if (stride == 3) out[3 * v + std::size_t(a)] = inv(a, a);
        for (int c = 0; stride == 9 && c < 3; ++c) out[9 * v + std::size_t(3 * a + c)] = inv(a, c);
      }
    }
    return out;
  }
};

// x from a dense LU solve with the fixed entries prescribed (A_ff x_f = b_f - A_fc x_c).
Eigen::VectorXd directSolution(const AssembledSystem& s, const Eigen::VectorXd& prescribed) {
  const std::size_t dofs = s.b.size();
  Eigen::VectorXd rhs = Eigen::Map<const Eigen::VectorXd>(s.b.data(), Eigen::Index(dofs)) - s.full * prescribed;
  for (std::size_t i = 0; i < dofs; ++i)
    if (!s.freeDof[i]) rhs[Eigen::Index(i)] = prescribed[Eigen::Index(i)];
  return s.dense.partialPivLu().solve(rhs);  // LU: no symmetry assumed
}

TEST(BlockPcg, ReachesTheDirectSolutionAndKeepsFixedEntries) {
  const AssembledSystem s;
  const std::size_t dofs = s.b.size();
  // Fixed entries are prescribed values (x_c): the free ones solve A_ff x_f = b_f - A_fc x_c.
  Eigen::VectorXd prescribed = Eigen::VectorXd::Zero(Eigen::Index(dofs));
  for (std::size_t i = 0; i < dofs; ++i)
    if (!s.freeDof[i]) prescribed[Eigen::Index(i)] = 1e-3 * (0.5 + double(i % 5));
  const Eigen::VectorXd exact = directSolution(s, prescribed);
  for (int stride : {3, 9}) {
    std::vector<double> x(dofs);
    for (std::size_t i = 0; i < dofs; ++i) x[i] = prescribed[Eigen::Index(i)];
    BlockPcgScratch scratch;
    const PcgResult r = solveBlockPcg(s.matrix, s.inverse(stride), stride, s.b, s.freeDof, x, 5000, 1e-10, scratch);
    EXPECT_TRUE(r.converged) << "stride " << stride;
    EXPECT_LE(r.relativeResidual, 1e-10);
    double diff = 0;
    for (std::size_t i = 0; i < dofs; ++i) {
      if (!s.freeDof[i]) {
        EXPECT_EQ(x[i], prescribed[Eigen::Index(i)]);
        continue;
      }
      diff = std::max(diff, std::abs(x[i] - exact[Eigen::Index(i)]));
    }
    EXPECT_LT(diff, 1e-7 * exact.cwiseAbs().maxCoeff()) << "stride " << stride;
  }
}

TEST(BlockPcg, TakesTheIterationsOfTextbookPcgWithTheSamePreconditioner) {
  const AssembledSystem s;
  const std::size_t dofs = s.b.size();
  const LinearOperator A = [&](const double* x, double* y) { s.matrix.multiply(x, y); };
  int fused[2] = {0, 0};
  for (int k = 0; k < 2; ++k) {
    const int stride = k == 0 ? 3 : 9;
    const std::vector<double> inverse = s.inverse(stride);
    const PreconditionerOperator P = [&](const double* r, double* z) {
      for (std::size_t v = 0; v < dofs / 3; ++v)
        for (std::size_t a = 0; a < 3; ++a) {
          const double* row = inverse.data() + std::size_t(stride) * v + (stride == 9 ? 3 * a : a);
          z[3 * v + a] = stride == 9 ? row[0] * r[3 * v] + row[1] * r[3 * v + 1] + row[2] * r[3 * v + 2] : row[0] * r[3 * v + a];
        }
    };
    std::vector<double> x(dofs, 0.0), y(dofs, 0.0);
    BlockPcgScratch scratch;
    const PcgResult f = solveBlockPcg(s.matrix, inverse, stride, s.b, s.freeDof, x, 5000, 1e-6, scratch);
    const PcgResult t = solvePcg(A, P, s.b, s.freeDof, y, 5000, 1e-6);
    EXPECT_TRUE(f.converged && t.converged);
    EXPECT_LE(std::abs(f.iterations - t.iterations), 2) << "stride " << stride << ": " << f.iterations << " vs " << t.iterations;
    EXPECT_GT(f.iterations, 10);  // not a trivial system
    fused[k] = f.iterations;
  }
  EXPECT_LE(fused[1], fused[0]);  // block-Jacobi needs no more iterations than Jacobi
}

TEST(BlockPcg, CoarseCorrectionReachesTheDirectSolutionInFewerIterations) {
  const AssembledSystem s;
  const std::size_t dofs = s.b.size();
  const Eigen::VectorXd exact = directSolution(s, Eigen::VectorXd::Zero(Eigen::Index(dofs)));
  CoarseCorrection coarse;
  coarse.setAggregates(s.mesh.restPositions, 27);
  EXPECT_GT(coarse.aggregateCount(), 4u);
  ASSERT_TRUE(coarse.factor(s.matrix, s.freeDof, s.mesh.restPositions));
  int iterations[2] = {0, 0};
  for (int withCoarse = 0; withCoarse < 2; ++withCoarse) {
    std::vector<double> x(dofs, 0.0);
    BlockPcgScratch scratch;
    const PcgResult r = solveBlockPcg(s.matrix, s.inverse(9), 9, s.b, s.freeDof, x, 5000, 1e-10, scratch,
                                      withCoarse ? &coarse : nullptr);
    EXPECT_TRUE(r.converged);
    double diff = 0;
    for (std::size_t i = 0; i < dofs; ++i) diff = std::max(diff, std::abs(x[i] - exact[Eigen::Index(i)]));
    EXPECT_LT(diff, 1e-7 * exact.cwiseAbs().maxCoeff()) << "coarse " << withCoarse;
    iterations[withCoarse] = r.iterations;
  }
  EXPECT_LT(iterations[1], iterations[0]) << iterations[1] << " vs " << iterations[0];
}

// A block fixed at its base, sagging and pressed by a sphere: with and without the coarse
// correction, the same step to a tight tolerance gives the same velocities; at the default
// tolerance both converge every step and the correction needs far fewer iterations.
SimulationSettings pressedBlock(int coarseNodes, double tolerance) {
  SimulationSettings settings;
  settings.materials = {Material{1e5, 0.45, 1000}};
  settings.fixed = [](const mesh::Double3& p) { return p.y < 1e-9; };
  settings.cgTolerance = tolerance;
  settings.coarseAggregateNodes = coarseNodes;
  Tool probe;
  probe.radius = 0.02;
  probe.stiffness = 2e3;
  probe.path = {{0.0, {0.05, 0.1, 0.05}}, {1.0, {0.05, 0.07, 0.05}}};
  settings.tools = {probe};
  return settings;
}

TEST(BlockPcg, CoarseCorrectionGivesTheSameStepInFewerIterations) {
  const mesh::TetMesh m = test::boxMesh(0.1, 0.08, 0.1, 0.01);
  {
    Simulation off(m, pressedBlock(0, 1e-9)), on(m, pressedBlock(64, 1e-9));
    off.run(3);
    on.run(3);
    double diff = 0, size = 0;
    for (std::size_t i = 0; i < m.nodeCount(); ++i) {
      diff = std::max(diff, test::norm(mesh::Double3{off.velocities()[i].x - on.velocities()[i].x,
                                                     off.velocities()[i].y - on.velocities()[i].y,
                                                     off.velocities()[i].z - on.velocities()[i].z}));
      size = std::max(size, test::norm(off.velocities()[i]));
    }
    EXPECT_GT(size, 1e-3);
    EXPECT_LT(diff, 1e-6 * size);
  }
  Simulation off(m, pressedBlock(0, 1e-3)), on(m, pressedBlock(64, 1e-3));
  off.run(40);
  on.run(40);
  EXPECT_EQ(off.solverSummary().capHits, 0);
  EXPECT_EQ(on.solverSummary().capHits, 0);
  EXPECT_LT(double(on.solverSummary().iterations), 0.6 * double(off.solverSummary().iterations))
      << on.solverSummary().iterations << " vs " << off.solverSummary().iterations;
}

}  // namespace
}  // namespace blobvk::fem
