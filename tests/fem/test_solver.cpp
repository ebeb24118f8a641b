// The implicit solve: the assembled block system against the matrix-free operator, each
// preconditioner against a dense direct solve, convergence and its reporting (stats, summary,
// one warning line at the cap), and thread-count independence with each preconditioner.
#include "blobvk/fem/block_system.h"
#include "blobvk/fem/elements.h"
#include "blobvk/fem/pcg.h"
#include "blobvk/fem/preconditioner.h"
#include "blobvk/fem/simulation.h"
#include "blobvk/fem/tet_utils.h"
#include "test_helpers.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cmath>
#include <random>
#include <string>

#include <Eigen/Dense>

namespace blobvk::fem {
namespace {

using mesh::Double3;

// A two-material box (the stiff half 500x the soft one, as bone against brain) with its nodes
// displaced by a rotation and noise, so rotations and rotated gradients are not trivial.
struct DeformedBox {
  mesh::TetMesh mesh;
  std::vector<Material> materials{Material{2e4, 0.45, 1000}, Material{1e7, 0.3, 1900}};
  DeformedBox() {
    mesh = test::boxMesh(0.2, 0.1, 0.1, 0.05);
    assignRegions(mesh, [](const Double3& c) { return c.x > 0.1 ? 1u : 0u; });
    std::mt19937 random(7);
    std::uniform_real_distribution<double> noise(-0.004, 0.004);
    const Eigen::Matrix3d R = Eigen::AngleAxisd(0.6, Eigen::Vector3d(1, 2, 0.5).normalized()).toRotationMatrix();
    for (auto& p : mesh.positions) {
      const Eigen::Vector3d q = R * Eigen::Vector3d(p.x, p.y, p.z);
      p = {q.x() + noise(random), q.y() + noise(random), q.z() + noise(random)};
    }
  }
};

TEST(Solver, AssembledBlocksEqualTheMatrixFreeOperator) {
  DeformedBox box;
  ElementSet elements;
  elements.build(box.mesh, box.materials);
  const std::size_t n = box.mesh.nodeCount();
  std::vector<double> force(3 * n), blocks(6 * n), nodeScale(n);
  elements.computeForces(box.mesh.positions, 30, force.data(), blocks.data());
  for (std::size_t i = 0; i < n; ++i) nodeScale[i] = 0.01 * double(i % 7 + 1);
  const double scale = 3e-4;
  BlockSystem system;
  buildBlockPattern(elements.incidence(), box.mesh.tets, system);
  elements.assembleSystem(system, nodeScale.data(), scale);
  std::mt19937 random(3);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int trial = 0; trial < 3; ++trial) {
    std::vector<double> p(3 * n), matrixFree(3 * n), assembled(3 * n, 0.0);
    for (double& v : p) v = u(random);
    elements.applySystem(p.data(), matrixFree.data(), nodeScale.data(), scale);
    for (std::size_t r = 0; r < n; ++r)
      for (std::uint32_t k = system.rowStart[r]; k < system.rowStart[r + 1]; ++k) {
        const double* b = system.values.data() + 9 * std::size_t(k);
        const double* x = p.data() + 3 * std::size_t(system.column[k]);
        for (int a = 0; a < 3; ++a) assembled[3 * r + std::size_t(a)] += b[3 * a] * x[0] + b[3 * a + 1] * x[1] + b[3 * a + 2] * x[2];
      }
    double diff = 0, size = 0;
    for (std::size_t i = 0; i < 3 * n; ++i) {
      diff = std::max(diff, std::abs(assembled[i] - matrixFree[i]));
      size = std::max(size, std::abs(matrixFree[i]));
    }
    EXPECT_LT(diff, 1e-12 * size) << "trial " << trial;
  }
  // The per-node diagonal blocks of the tet pass (the block-Jacobi input) are the assembled ones.
  for (std::size_t r = 0; r < n; ++r) {
    const double* d = system.values.data() + 9 * std::size_t(system.diagonal[r]);
    const double* b = blocks.data() + 6 * r;
    const double expected[9] = {b[0], b[3], b[4], b[3], b[1], b[5], b[4], b[5], b[2]};
    for (int k = 0; k < 9; ++k) {
      const double withMass = expected[k] * scale + ((k % 4 == 0) ? nodeScale[r] : 0.0);
      EXPECT_NEAR(d[k], withMass, 1e-12 * std::abs(d[0])) << "node " << r << " entry " << k;
    }
  }
}

TEST(Solver, EveryPreconditionerReachesTheDirectSolution) {
  DeformedBox box;
  ElementSet elements;
  elements.build(box.mesh, box.materials);
  const std::size_t n = box.mesh.nodeCount(), dofs = 3 * n;
  std::vector<double> force(dofs), blocks(6 * n), nodeScale(n);
  elements.computeForces(box.mesh.positions, 30, force.data(), blocks.data());
  const std::vector<double> mass = elements.lumpedMass();
  const double scale = 2e-4;  // h beta + h^2 at h = 0.01, beta = 0.01: stiffness-dominated
  for (std::size_t i = 0; i < n; ++i) nodeScale[i] = 1.5 * mass[i];
  std::vector<unsigned char> freeDof(dofs, 1);
  for (std::size_t i = 0; i < n; ++i)
    if (box.mesh.restPositions[i].x < 1e-9) freeDof[3 * i] = freeDof[3 * i + 1] = freeDof[3 * i + 2] = 0;
  // Oracle: the dense matrix from the operator's columns, restricted to free DOFs, solved by LDLT.
  Eigen::MatrixXd dense(dofs, dofs);
  std::vector<double> e(dofs, 0.0), column(dofs);
  for (std::size_t j = 0; j < dofs; ++j) {
    e[j] = 1;
    elements.applySystem(e.data(), column.data(), nodeScale.data(), scale);
    e[j] = 0;
    for (std::size_t i = 0; i < dofs; ++i) dense(Eigen::Index(i), Eigen::Index(j)) = column[i];
  }
  for (std::size_t i = 0; i < dofs; ++i)
    if (!freeDof[i]) {
      dense.row(Eigen::Index(i)).setZero();
      dense.col(Eigen::Index(i)).setZero();
      dense(Eigen::Index(i), Eigen::Index(i)) = 1;
    }
  std::vector<double> b(dofs);
  for (std::size_t i = 0; i < dofs; ++i) b[i] = freeDof[i] ? force[i] * 0.01 + 0.001 * mass[i / 3] : 0.0;
  const Eigen::VectorXd exact = dense.ldlt().solve(Eigen::Map<const Eigen::VectorXd>(b.data(), Eigen::Index(dofs)));
  const LinearOperator A = [&](const double* x, double* y) { elements.applySystem(x, y, nodeScale.data(), scale); };

  std::vector<double> diagonal(blocks);  // A's diagonal blocks: nodeScale I + scale K_ii
  for (std::size_t i = 0; i < n; ++i)
    for (int k = 0; k < 6; ++k) diagonal[6 * i + std::size_t(k)] = (k < 3 ? nodeScale[i] : 0.0) + scale * blocks[6 * i + std::size_t(k)];
  BlockSystem system;
  buildBlockPattern(elements.incidence(), box.mesh.tets, system);
  elements.assembleSystem(system, nodeScale.data(), scale);
  int iterations[3] = {0, 0, 0};
  for (int kind = 0; kind < 3; ++kind) {
    SystemPreconditioner P;
    if (kind == 2) {
      ASSERT_TRUE(P.factorize(system, freeDof, true));
    } else {
      P.setDiagonalBlocks(PreconditionerKind(kind), diagonal, freeDof);
    }
    std::vector<double> x(dofs, 0.0);
    const PcgResult r = solvePcg(A, [&](const double* in, double* out) { P.apply(in, out); }, b, freeDof, x, 5000, 1e-10);
    EXPECT_TRUE(r.converged) << "kind " << kind;
    EXPECT_LE(r.relativeResidual, 1e-10);
    double diff = 0;
    for (std::size_t i = 0; i < dofs; ++i) diff = std::max(diff, std::abs(x[i] - exact[Eigen::Index(i)]));
    EXPECT_LT(diff, 1e-7 * exact.cwiseAbs().maxCoeff()) << "kind " << kind;
    iterations[kind] = r.iterations;
  }
  // The stronger preconditioners take fewer iterations on this stiffness-dominated system.
  EXPECT_LT(iterations[2], iterations[1]);
  EXPECT_LE(iterations[1], iterations[0]);
}

SimulationSettings pressedSettings(PreconditionerKind kind) {
  SimulationSettings s;
  s.materials = {Material{2e4, 0.45, 1000}, Material{1e7, 0.3, 1900}};
  s.timeStep = 0.01;
  s.rayleighMass = 0.5;
  s.fixed = [](const Double3& p) { return p.y < 1e-9; };
  s.preconditioner = kind;
  Tool tool;
  tool.radius = 0.04;
  tool.stiffness = 2e4;
  tool.path = {{0.0, {0.15, 0.24, 0.1}}, {0.3, {0.15, 0.14, 0.1}}};
  s.tools = {tool};
  return s;
}

mesh::TetMesh twoTissueBlock() {
  mesh::TetMesh m = test::boxMesh(0.3, 0.2, 0.2, 0.025);
  assignRegions(m, [](const Double3& c) { return c.y < 0.1 ? 1u : 0u; });  // stiff bottom layer
  return m;
}

// The case that used to stop at the cap every step: a stiff layer under a soft one, pressed.
TEST(Solver, DefaultsMeetTheToleranceOnAStiffAndSoftBody) {
  for (PreconditionerKind kind : {PreconditionerKind::BlockJacobi, PreconditionerKind::IncompleteCholesky}) {
    int warnings = 0;
    SimulationSettings s = pressedSettings(kind);
    s.onWarning = [&](const std::string&) { ++warnings; };
    Simulation sim(twoTissueBlock(), s);
    for (int step = 0; step < 25; ++step) {
      sim.step();
      EXPECT_TRUE(sim.lastStats().cgConverged) << "step " << step;
      EXPECT_LE(sim.lastStats().cgRelativeResidual, s.cgTolerance);
      EXPECT_GT(sim.lastStats().cgIterations, 0);
    }
    EXPECT_GT(sim.toolContacts()[0].nodesInContact, 0u);
    const SolverSummary& summary = sim.solverSummary();
    EXPECT_EQ(summary.steps, 25);
    EXPECT_EQ(summary.capHits, 0);
    EXPECT_EQ(warnings, 0);
    EXPECT_LE(summary.maxRelativeResidual, s.cgTolerance);
    if (kind == PreconditionerKind::IncompleteCholesky) {
      EXPECT_GE(summary.preconditionerBuilds, 3);  // every 10 steps
    }
  }
}

// A solve that broke down (NaN residual) must show in the summary's maximum, whichever step it
// came at: std::max(x, NaN) would keep x and report the run as within tolerance.
TEST(Solver, ANanResidualIsTheLargest) {
  const double nan = std::nan("");
  EXPECT_TRUE(std::isnan(worseResidual(1e-4, nan)));
  EXPECT_TRUE(std::isnan(worseResidual(nan, 1e-4)));
  EXPECT_TRUE(std::isnan(worseResidual(worseResidual(0, nan), 0.5)));
  EXPECT_EQ(worseResidual(1e-4, 2e-4), 2e-4);
  EXPECT_EQ(worseResidual(3e-4, 2e-4), 3e-4);
}

TEST(Solver, TheCapIsReportedOnceAndCountedEveryTime) {
  SimulationSettings s = pressedSettings(PreconditionerKind::BlockJacobi);
  s.cgMaxIterations = 3;
  s.cgTolerance = 1e-12;
  std::vector<std::string> lines;
  Simulation sim(twoTissueBlock(), s);
  sim.setWarningHandler([&](const std::string& line) { lines.push_back(line); });
  sim.run(5);
  ASSERT_EQ(lines.size(), 1u);
  EXPECT_NE(lines[0].find("cap of 3 iterations"), std::string::npos) << lines[0];
  EXPECT_EQ(lines[0].find('\n'), std::string::npos);  // one line
  EXPECT_FALSE(sim.lastStats().cgConverged);
  EXPECT_EQ(sim.lastStats().cgIterations, 3);
  EXPECT_GT(sim.lastStats().cgRelativeResidual, 1e-12);
  EXPECT_EQ(sim.solverSummary().capHits, 5);
  EXPECT_EQ(sim.solverSummary().iterations, 15);
}

// The same bytes with one thread and with all of them, for each preconditioner, across a
// refresh of the incomplete factor and a topology change (which rebuilds its pattern).
TEST(Solver, StepsDoNotDependOnTheThreadCountWithAnyPreconditioner) {
  for (int kind = 0; kind < 3; ++kind) {
    auto run = [kind] {
      SimulationSettings s = pressedSettings(PreconditionerKind(kind));
      s.cgTolerance = 1e-6;
      s.preconditionerRefreshSteps = 4;
      Simulation sim(test::boxMesh(0.3, 0.2, 0.2, 0.05), s);
      sim.run(6);
      // Split the tet of slot 0 at its centroid (1 -> 4 tets, one new node).
      const auto t = sim.mesh().tets[0];
      TopologyChange change;
      NodeOrigin centre;
      for (int i = 0; i < 4; ++i) {
        centre.sources[std::size_t(i)] = t[std::size_t(i)];
        centre.weights[std::size_t(i)] = 0.25;
      }
      change.newNodes = {centre};
      const std::uint32_t c = std::uint32_t(sim.mesh().nodeCount());
      change.tetSlots = {0, std::uint32_t(sim.mesh().tetCount()), std::uint32_t(sim.mesh().tetCount() + 1),
                         std::uint32_t(sim.mesh().tetCount() + 2)};
      change.tetNodes = {{t[0], t[1], t[2], c}, {t[0], t[1], c, t[3]}, {t[0], c, t[2], t[3]}, {c, t[1], t[2], t[3]}};
      change.tetRegions = {0, 0, 0, 0};
      sim.applyTopologyChange(change);
      sim.run(6);
      return std::make_pair(sim.positions(), sim.solverSummary().iterations);
    };
    std::pair<std::vector<Double3>, long long> serial;
    {
      tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
      serial = run();
    }
    const auto parallel = run();
    EXPECT_EQ(serial.second, parallel.second) << "kind " << kind;
    ASSERT_EQ(serial.first.size(), parallel.first.size());
    for (std::size_t i = 0; i < serial.first.size(); ++i) {
      ASSERT_EQ(serial.first[i].x, parallel.first[i].x) << "kind " << kind << " node " << i;
      ASSERT_EQ(serial.first[i].y, parallel.first[i].y) << "kind " << kind << " node " << i;
      ASSERT_EQ(serial.first[i].z, parallel.first[i].z) << "kind " << kind << " node " << i;
    }
  }
}

}  // namespace
}  // namespace blobvk::fem
