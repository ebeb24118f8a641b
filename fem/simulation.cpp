#include "blobvk/fem/simulation.h"

#include "blobvk/fem/block_pcg.h"
#include "blobvk/fem/block_system.h"
#include "blobvk/fem/boundary_faces.h"
#include "blobvk/fem/elements.h"
#include "blobvk/fem/pcg.h"
#include "blobvk/fem/preconditioner.h"
#include "blobvk/fem/coarse_correction.h"
#include "blobvk/fem/reserve_touched.h"
#include "blobvk/fem/system_matrix.h"
#include "blobvk/fem/tet_utils.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <cstdio>
#include <string>

#include <tbb/parallel_for.h>

namespace blobvk::fem {
namespace {

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }

}  // namespace

struct Simulation::Impl {
  mesh::TetMesh mesh;
  SimulationSettings settings;
  ElementSet elements;
  BoundaryFaceSet boundary;
  std::vector<double> mass;
  std::vector<mesh::Double3> velocity;
  std::vector<unsigned char> fixed, freeDof;
  std::vector<double> force, rhs, solution;
  std::vector<double> previousVelocity;  // 3 per node: the velocity one step back (warm start)
  // The system A = (1 + h alpha) M + (h beta + h^2) K~ + contact, applied matrix-free:
  // nodeScale = (1 + h alpha) m per node, diagonalBlocks = A's 3x3 node blocks (6 per node:
  // xx, yy, zz, xy, xz, yz) for the (block-)Jacobi preconditioners.
  std::vector<double> nodeScale, diagonalBlocks;
  // A itself, assembled once per step for CG's products. Its pattern is built at the first
  // step; a topology change lists the rows it changes (matrixRows), updated at the next step.
  SystemMatrix matrix;
  bool matrixPatternDirty = true;
  std::vector<std::uint32_t> matrixRows;
  BlockPcgScratch pcgScratch;
  // The two-level correction of the (block-)Jacobi CG (coarse_correction.h), set up at the
  // first step; useCoarse: its factor of this step's system is valid.
  CoarseCorrection coarse;
  bool coarseAggregates = false, useCoarse = false;
  // The incomplete Cholesky preconditioner: A assembled as blocks, its factor, and when to
  // rebuild it (patternDirty: the mesh changed; factorDirty: the fixed set changed).
  BlockSystem blockSystem;
  SystemPreconditioner preconditioner;
  bool patternDirty = true, factorDirty = true, haveFactor = false;
  int stepsSinceFactor = 0, iterationsAfterFactor = 0, lastIterations = 0;
  SolverSummary summary;
  struct ContactBlock {
    std::uint32_t node;
    double block[9];  // h^2 k n n^T, row-major
  };
  std::vector<ContactBlock> contactBlocks;
  std::vector<ToolContactReport> contacts;
  std::vector<ToolPose> toolPoses;  // setToolPoses: in place of the paths when not empty
  StepStats stats;
  double time = 0;
  mesh::TriMesh renderMesh;
  SurfaceEmbedding embedding;
  bool embedded = false;
  // Per-node contact scratch: depth, normal and tool of the deepest contact.
  std::vector<double> contactDepth;
  std::vector<mesh::Double3> contactNormal;
  // Topology-change scratch, kept so that a change allocates nothing: a per-node mark (equal to
  // markEpoch when the node is in touchedNodes) and the overwritten versions of rewritten tets.
  std::vector<std::uint32_t> nodeMark, touchedNodes;
  std::uint32_t markEpoch = 0;
  std::vector<std::array<std::uint32_t, 4>> overwrittenTets;

  void addToolContacts(double h);
  void applyFloor();
  // Sets the preconditioner up for this step's system; true when the factor was rebuilt.
  bool preparePreconditioner(double stiffnessScale);
  void recordSolve(const StepStats& stats);
};

bool Simulation::Impl::preparePreconditioner(double stiffnessScale) {
  const PreconditionerKind kind = settings.preconditioner;
  if (kind != PreconditionerKind::IncompleteCholesky) {
    preconditioner.setDiagonalBlocks(kind, diagonalBlocks, freeDof);
    useCoarse = settings.coarseAggregateNodes > 0;
    if (useCoarse && !coarseAggregates) {
      coarse.setAggregates(mesh.restPositions, std::size_t(settings.coarseAggregateNodes));
      coarseAggregates = true;
    }
    if (useCoarse) useCoarse = coarse.factor(matrix, freeDof, mesh.restPositions);
    return false;
  }
  const int refresh = settings.preconditionerRefreshSteps;
  const bool slow = haveFactor && lastIterations > 2 * iterationsAfterFactor + 5;
  if (haveFactor && !patternDirty && !factorDirty && stepsSinceFactor < refresh && !slow) {
    ++stepsSinceFactor;
    return false;
  }
  if (patternDirty) buildBlockPattern(elements.incidence(), mesh.tets, blockSystem);
  elements.assembleSystem(blockSystem, nodeScale.data(), stiffnessScale);
  for (const ContactBlock& c : contactBlocks) {
    double* block = blockSystem.values.data() + 9 * std::size_t(blockSystem.diagonal[c.node]);
    for (int k = 0; k < 9; ++k) block[k] += c.block[k];
  }
  haveFactor = preconditioner.factorize(blockSystem, freeDof, patternDirty);
  patternDirty = factorDirty = false;
  stepsSinceFactor = 1;
  iterationsAfterFactor = -1;  // set by the next solve
  if (!haveFactor) preconditioner.setDiagonalBlocks(PreconditionerKind::BlockJacobi, diagonalBlocks, freeDof);
  return true;
}

void Simulation::Impl::recordSolve(const StepStats& s) {
  if (iterationsAfterFactor < 0) iterationsAfterFactor = s.cgIterations;
  lastIterations = s.cgIterations;
  ++summary.steps;
  summary.iterations += s.cgIterations;
  summary.maxIterations = std::max(summary.maxIterations, s.cgIterations);
  summary.maxRelativeResidual = worseResidual(summary.maxRelativeResidual, s.cgRelativeResidual);
  if (s.preconditionerRebuilt) ++summary.preconditionerBuilds;
  if (s.cgConverged) return;
  if (++summary.capHits == 1 && settings.onWarning) {
    char line[200];
    std::snprintf(line, sizeof line,
                  "fem: CG stopped at its cap of %d iterations at t = %.4g s with relative residual %.3g > tolerance %.3g "
                  "(later steps that do are counted, not reported)",
                  settings.cgMaxIterations, time, s.cgRelativeResidual, settings.cgTolerance);
    settings.onWarning(line);
  }
}

Simulation::Simulation(mesh::TetMesh m, SimulationSettings s) : impl_(std::make_unique<Impl>()) {
  validateTetMesh(m);
  if (s.materials.empty()) throw std::invalid_argument("simulation: at least one material is needed");
  for (std::size_t r = 0; r < s.materials.size(); ++r) validateMaterial(s.materials[r], r);
  for (std::size_t t = 0; t < m.regions.size(); ++t)
    if (m.regions[t] >= s.materials.size())
      throw std::invalid_argument("tet " + std::to_string(t) + " has region " + std::to_string(m.regions[t]) + " but only " +
                                  std::to_string(s.materials.size()) + " materials are given");
  if (!(s.timeStep > 0) || !std::isfinite(s.timeStep)) throw std::invalid_argument("simulation: time step must be > 0");
  if (s.rayleighMass < 0 || s.rayleighStiffness < 0) throw std::invalid_argument("simulation: Rayleigh coefficients must be >= 0");
  if (s.cgMaxIterations < 1) throw std::invalid_argument("simulation: cgMaxIterations must be >= 1");
  if (!(s.cgTolerance >= 0)) throw std::invalid_argument("simulation: cgTolerance must be >= 0");
  if (s.preconditionerRefreshSteps < 1) throw std::invalid_argument("simulation: preconditionerRefreshSteps must be >= 1");
  if (s.coarseAggregateNodes < 0) throw std::invalid_argument("simulation: coarseAggregateNodes must be >= 0");
  for (std::size_t k = 0; k < s.tools.size(); ++k) validateTool(s.tools[k], k);
  if (s.floor) {
    const auto& n = s.floor->normal;
    const double len = std::sqrt(n.x * n.x + n.y * n.y + n.z * n.z);
    if (!(len > 0)) throw std::invalid_argument("simulation: floor normal must be non-zero");
    s.floor->normal = {n.x / len, n.y / len, n.z / len};
    s.floor->offset /= len;
  }
  Impl& d = *impl_;
  d.mesh = std::move(m);
  d.settings = std::move(s);
  if (d.mesh.boundaryFaces.empty()) d.mesh.boundaryFaces = findBoundaryFaces(d.mesh);
  d.boundary.build(d.mesh.boundaryFaces);
  d.elements.build(d.mesh, d.settings.materials, d.settings.cutRoom);
  d.mass = d.elements.lumpedMass();
  const std::size_t n = d.mesh.nodeCount();
  d.velocity.assign(n, {});
  d.fixed.assign(n, 0);
  for (std::size_t i = 0; i < n; ++i)
    if (d.settings.fixed && d.settings.fixed(d.mesh.restPositions[i])) d.fixed[i] = 1;
  for (auto i : d.settings.fixedNodes) {
    if (i >= n) throw std::invalid_argument("simulation: fixed node " + std::to_string(i) + " out of range");
    d.fixed[i] = 1;
  }
  d.freeDof.resize(3 * n);
  for (std::size_t i = 0; i < 3 * n; ++i) d.freeDof[i] = d.fixed[i / 3] ? 0 : 1;
  d.force.assign(3 * n, 0);
  d.nodeScale.assign(n, 0);
  d.diagonalBlocks.assign(6 * n, 0);
  d.rhs.assign(3 * n, 0);
  d.solution.assign(3 * n, 0);
  d.previousVelocity.assign(3 * n, 0);
  d.contacts.assign(d.settings.tools.size(), {});
  d.contactDepth.assign(n, 0);
  d.contactNormal.assign(n, {});
  d.nodeMark.assign(n, 0);
  // Room for the nodes of later cuts, so that a topology change does not copy every array.
  const std::size_t room = withCutRoom(n, d.settings.cutRoom);
  for (auto* v : {&d.mesh.positions, &d.mesh.restPositions, &d.velocity, &d.contactNormal}) reserveTouched(*v, room);
  for (auto* v : {&d.mass, &d.contactDepth, &d.nodeScale}) reserveTouched(*v, room);
  for (auto* v : {&d.force, &d.rhs, &d.solution, &d.previousVelocity}) reserveTouched(*v, 3 * room);
  reserveTouched(d.diagonalBlocks, 6 * room);
  reserveTouched(d.nodeMark, room);
  reserveTouched(d.fixed, room);
  reserveTouched(d.freeDof, 3 * room);
  const std::size_t tetRoom = withCutRoom(d.mesh.tets.size(), d.settings.cutRoom);
  reserveTouched(d.mesh.tets, tetRoom);
  if (!d.mesh.regions.empty()) reserveTouched(d.mesh.regions, tetRoom);
}

Simulation::~Simulation() = default;
Simulation::Simulation(Simulation&&) noexcept = default;
Simulation& Simulation::operator=(Simulation&&) noexcept = default;

void Simulation::Impl::addToolContacts(double h) {
  const std::size_t n = mesh.nodeCount();
  for (std::size_t k = 0; k < settings.tools.size(); ++k) {
    const Tool& tool = settings.tools[k];
    const ToolPose pose = toolPoses.empty() ? tool.poseAt(time + h) : toolPoses[k];
    const double reach = tool.boundingRadius();
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 1024), [&](const tbb::blocked_range<std::size_t>& r) {
      for (std::size_t i = r.begin(); i != r.end(); ++i) {
        contactDepth[i] = 0;
        if (fixed[i]) continue;
        const auto& p = mesh.positions[i];
        const double dx = p.x - pose.position.x, dy = p.y - pose.position.y, dz = p.z - pose.position.z;
        if (dx * dx + dy * dy + dz * dz > reach * reach) continue;  // broad phase
        const ToolContact c = tool.contact(p, pose);
        if (c.depth > 0) {
          contactDepth[i] = c.depth;
          contactNormal[i] = c.normal;
        }
      }
    });
    // Serial accumulation keeps the reported totals deterministic.
    ToolContactReport report;
    const double kh2 = tool.stiffness * h * h;
    for (std::size_t i = 0; i < n; ++i) {
      if (contactDepth[i] <= 0) continue;
      const auto& nn = contactNormal[i];
      const double f = tool.stiffness * contactDepth[i];
      force[3 * i] += f * nn.x;
      force[3 * i + 1] += f * nn.y;
      force[3 * i + 2] += f * nn.z;
      // Implicit penalty: d f / d x = -k n n^T enters (M + h D + h^2 K) as + h^2 k n n^T.
      ContactBlock& block = contactBlocks.emplace_back();
      block.node = std::uint32_t(i);
      const double nv[3] = {nn.x, nn.y, nn.z};
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) block.block[a * 3 + b] = kh2 * nv[a] * nv[b];
      ++report.nodesInContact;
      report.force.x += f * nn.x;
      report.force.y += f * nn.y;
      report.force.z += f * nn.z;
      report.maxDepth = std::max(report.maxDepth, contactDepth[i]);
    }
    contacts[k] = report;
  }
}

void Simulation::Impl::applyFloor() {
  if (!settings.floor) return;
  const FloorPlane& f = *settings.floor;
  for (std::size_t i = 0; i < mesh.nodeCount(); ++i) {
    auto& p = mesh.positions[i];
    const double s = f.normal.x * p.x + f.normal.y * p.y + f.normal.z * p.z - f.offset;
    if (s >= 0 || fixed[i]) continue;
    p = {p.x - s * f.normal.x, p.y - s * f.normal.y, p.z - s * f.normal.z};
    auto& v = velocity[i];
    const double vn = f.normal.x * v.x + f.normal.y * v.y + f.normal.z * v.z;
    const mesh::Double3 vt{v.x - vn * f.normal.x, v.y - vn * f.normal.y, v.z - vn * f.normal.z};
    const double normalPart = vn < 0 ? -f.restitution * vn : vn;
    const double keep = 1.0 - f.friction;
    v = {keep * vt.x + normalPart * f.normal.x, keep * vt.y + normalPart * f.normal.y, keep * vt.z + normalPart * f.normal.z};
  }
}

void Simulation::step() {
  Impl& d = *impl_;
  const auto start = Clock::now();
  const double h = d.settings.timeStep;
  const std::size_t n = d.mesh.nodeCount();
  const double stiffnessScale = h * d.settings.rayleighStiffness + h * h;
  const double massScale = 1.0 + h * d.settings.rayleighMass;
  StepStats stats;

  // A = (1 + h alpha) M + (h beta + h^2) K~ ; b = M v + h (f_elastic + f_gravity + f_contact).
  // rotationsMs: the per-tet pass (rotations, stresses, rotated gradients); assemblyMs: the
  // per-node gather of forces, mass terms and gravity, and the assembly of A (system_matrix.h).
  auto t = Clock::now();
  const ElasticPassResult pass = d.elements.computeForces(d.mesh.positions, d.settings.rotationMaxIterations, d.force.data(),
                                                          nullptr);
  stats.rotationIterationsPerTet = double(pass.rotationIterations) / double(d.elements.size());
  stats.rotationsMs = d.elements.lastTetPassMs();
  const auto& g = d.settings.gravity;
  for (std::size_t i = 0; i < n; ++i) {
    d.nodeScale[i] = massScale * d.mass[i];
    d.force[3 * i] += d.mass[i] * g.x;
    d.force[3 * i + 1] += d.mass[i] * g.y;
    d.force[3 * i + 2] += d.mass[i] * g.z;
  }
  stats.assemblyMs = msSince(t) - stats.rotationsMs;

  t = Clock::now();
  d.contactBlocks.clear();
  d.addToolContacts(h);
  stats.contactMs = msSince(t);

  t = Clock::now();
  if (d.matrixPatternDirty) {
    d.matrix.buildPattern(d.elements.incidence(), d.mesh.tets);
    d.matrixPatternDirty = false;
    stats.matrixPatternMs = msSince(t);
  } else if (!d.matrixRows.empty()) {
    std::sort(d.matrixRows.begin(), d.matrixRows.end());
    d.matrixRows.erase(std::unique(d.matrixRows.begin(), d.matrixRows.end()), d.matrixRows.end());
    d.matrix.updateRows(d.elements.incidence(), d.mesh.tets, d.matrixRows);
    stats.matrixPatternMs = msSince(t);
  }
  d.matrixRows.clear();
  d.elements.assembleMatrix(d.matrix, d.nodeScale.data(), stiffnessScale);
  for (const auto& c : d.contactBlocks) {
    double* block = d.matrix.diagonal(c.node);
    for (int k = 0; k < 9; ++k) block[k] += c.block[k];
  }
  // The (block-)Jacobi preconditioners read A's diagonal blocks as xx, yy, zz, xy, xz, yz.
  for (std::size_t i = 0; i < n; ++i) {
    const double* a = d.matrix.diagonal(i);
    double* block = d.diagonalBlocks.data() + 6 * i;
    block[0] = a[0];
    block[1] = a[4];
    block[2] = a[8];
    block[3] = a[1];
    block[4] = a[2];
    block[5] = a[5];
  }
  stats.assemblyMs += msSince(t);

  t = Clock::now();
  for (std::size_t i = 0; i < n; ++i) {
    const auto& v = d.velocity[i];
    const double vv[3] = {v.x, v.y, v.z};
    for (int c = 0; c < 3; ++c) {
      d.rhs[3 * i + c] = d.mass[i] * vv[c] + h * d.force[3 * i + c];
      // Warm start: the velocity extrapolated from the last two steps (in smooth motion the
      // change of v is nearly constant: ~30 % fewer iterations than starting from v).
      d.solution[3 * i + c] = d.fixed[i] ? 0.0 : 2 * vv[c] - d.previousVelocity[3 * i + c];
    }
  }
  const LinearOperator A = [&d](const double* x, double* y) { d.matrix.multiply(x, y); };
  stats.solveMs = msSince(t);
  t = Clock::now();
  stats.preconditionerRebuilt = d.preparePreconditioner(stiffnessScale);
  stats.preconditionerMs = msSince(t);
  t = Clock::now();
  PcgResult cg;
  if (d.preconditioner.kind() == PreconditionerKind::IncompleteCholesky) {
    const PreconditionerOperator P = [&d](const double* r, double* z) { d.preconditioner.apply(r, z); };
    cg = solvePcg(A, P, d.rhs, d.freeDof, d.solution, d.settings.cgMaxIterations, d.settings.cgTolerance);
  } else {  // (block-)Jacobi: the fused solver
    const int stride = d.preconditioner.kind() == PreconditionerKind::BlockJacobi ? 9 : 3;
    cg = solveBlockPcg(d.matrix, d.preconditioner.inverse(), stride, d.rhs, d.freeDof, d.solution, d.settings.cgMaxIterations,
                       d.settings.cgTolerance, d.pcgScratch, d.useCoarse ? &d.coarse : nullptr);
  }
  stats.cgIterations = cg.iterations;
  stats.cgRelativeResidual = cg.relativeResidual;
  stats.cgConverged = cg.converged;
  d.recordSolve(stats);
  for (std::size_t i = 0; i < n; ++i) {
    if (d.fixed[i]) {
      d.velocity[i] = {};
      continue;
    }
    d.previousVelocity[3 * i] = d.velocity[i].x;
    d.previousVelocity[3 * i + 1] = d.velocity[i].y;
    d.previousVelocity[3 * i + 2] = d.velocity[i].z;
    d.velocity[i] = {d.solution[3 * i], d.solution[3 * i + 1], d.solution[3 * i + 2]};
    auto& p = d.mesh.positions[i];
    p = {p.x + h * d.velocity[i].x, p.y + h * d.velocity[i].y, p.z + h * d.velocity[i].z};
  }
  d.applyFloor();
  stats.solveMs += msSince(t);
  d.time += h;
  stats.totalMs = msSince(start);
  d.stats = stats;
}

// The contract is in simulation.h: validates the whole change before touching the state, then
// edits only what the change touches (cost proportional to its size plus the boundary copy).
void Simulation::applyTopologyChange(const TopologyChange& c) {
  Impl& d = *impl_;
  auto fail = [](const std::string& why) { throw std::invalid_argument("topology change: " + why); };
  if (c.tetNodes.size() != c.tetSlots.size() || c.tetRegions.size() != c.tetSlots.size())
    fail("tetSlots, tetNodes and tetRegions differ in length");
  const std::size_t oldNodes = d.mesh.nodeCount();
  const std::size_t nodes = oldNodes + c.newNodes.size();
  std::vector<Double3> rest(c.newNodes.size()), pos(c.newNodes.size()), vel(c.newNodes.size());
  std::vector<unsigned char> fixedNew(c.newNodes.size(), 0);
  for (std::size_t k = 0; k < c.newNodes.size(); ++k) {
    const NodeOrigin& o = c.newNodes[k];
    bool allFixed = true, any = false;
    for (int i = 0; i < 4; ++i) {
      const std::uint32_t s = o.sources[std::size_t(i)];
      if (s == kNoSource) continue;
      if (s >= oldNodes + k) fail("new node " + std::to_string(oldNodes + k) + " has source " + std::to_string(s) + ", not an earlier node");
      const double w = o.weights[std::size_t(i)];
      if (!std::isfinite(w)) fail("new node " + std::to_string(oldNodes + k) + " has a non-finite weight");
      const bool isNew = s >= oldNodes;
      const Double3& r = isNew ? rest[s - oldNodes] : d.mesh.restPositions[s];
      const Double3& p = isNew ? pos[s - oldNodes] : d.mesh.positions[s];
      const Double3& v = isNew ? vel[s - oldNodes] : d.velocity[s];
      rest[k] = {rest[k].x + w * r.x, rest[k].y + w * r.y, rest[k].z + w * r.z};
      pos[k] = {pos[k].x + w * p.x, pos[k].y + w * p.y, pos[k].z + w * p.z};
      vel[k] = {vel[k].x + w * v.x, vel[k].y + w * v.y, vel[k].z + w * v.z};
      allFixed = allFixed && (isNew ? fixedNew[s - oldNodes] != 0 : d.fixed[s] != 0);
      any = true;
    }
    if (!any) fail("new node " + std::to_string(oldNodes + k) + " has no source");
    fixedNew[k] = (allFixed || (d.settings.fixed && d.settings.fixed(rest[k]))) ? 1 : 0;
  }
  // Moved nodes, each from the values just before it (earlier moves and new nodes included).
  const std::size_t moves = c.movedNodes.size();
  std::vector<Double3> movedRest(moves), movedPos(moves), movedVel(moves);
  std::vector<std::pair<std::uint32_t, std::uint32_t>> movedIndex;  // (node, its last move), sorted
  auto lastMove = [&](std::uint32_t v) -> std::ptrdiff_t {
    const auto it = std::lower_bound(movedIndex.begin(), movedIndex.end(), std::pair{v, 0u});
    return it != movedIndex.end() && it->first == v ? std::ptrdiff_t(it->second) : -1;
  };
  for (std::size_t k = 0; k < moves; ++k) {
    const NodeMove& mv = c.movedNodes[k];
    const std::string name = "moved node " + std::to_string(mv.node);
    if (mv.node >= nodes) fail(name + " does not exist (" + std::to_string(nodes) + " nodes)");
    Double3 r{}, p{}, v{};
    bool any = false;
    for (int i = 0; i < 4; ++i) {
      const std::uint32_t s = mv.origin.sources[std::size_t(i)];
      if (s == kNoSource) continue;
      if (s >= nodes) fail(name + " has source " + std::to_string(s) + " of " + std::to_string(nodes) + " nodes");
      const double w = mv.origin.weights[std::size_t(i)];
      if (!std::isfinite(w)) fail(name + " has a non-finite weight");
      const std::ptrdiff_t j = lastMove(s);
      const bool isNew = s >= oldNodes;
      const Double3& sr = j >= 0 ? movedRest[std::size_t(j)] : (isNew ? rest[s - oldNodes] : d.mesh.restPositions[s]);
      const Double3& sp = j >= 0 ? movedPos[std::size_t(j)] : (isNew ? pos[s - oldNodes] : d.mesh.positions[s]);
      const Double3& sv = j >= 0 ? movedVel[std::size_t(j)] : (isNew ? vel[s - oldNodes] : d.velocity[s]);
      r = {r.x + w * sr.x, r.y + w * sr.y, r.z + w * sr.z};
      p = {p.x + w * sp.x, p.y + w * sp.y, p.z + w * sp.z};
      v = {v.x + w * sv.x, v.y + w * sv.y, v.z + w * sv.z};
      any = true;
    }
    if (!any) fail(name + " has no source");
    movedRest[k] = r, movedPos[k] = p, movedVel[k] = v;
    const auto it = std::lower_bound(movedIndex.begin(), movedIndex.end(), std::pair{mv.node, 0u});
    if (it != movedIndex.end() && it->first == mv.node) it->second = std::uint32_t(k);
    else movedIndex.insert(it, {mv.node, std::uint32_t(k)});
  }
  std::size_t tetCount = d.mesh.tetCount();
  for (std::size_t k = 0; k < c.tetSlots.size(); ++k) {
    const std::uint32_t slot = c.tetSlots[k];
    if (slot > tetCount) fail("tet slot " + std::to_string(slot) + " is past the end (" + std::to_string(tetCount) + " tets)");
    if (slot == tetCount) ++tetCount;
    if (c.tetRegions[k] >= d.settings.materials.size()) fail("tet slot " + std::to_string(slot) + " has region " + std::to_string(c.tetRegions[k]) + " without a material");
    const auto& t = c.tetNodes[k];
    for (std::uint32_t v : t)
      if (v >= nodes) fail("tet slot " + std::to_string(slot) + " references node " + std::to_string(v) + " of " + std::to_string(nodes));
    if (t[0] == t[1] || t[0] == t[2] || t[0] == t[3] || t[1] == t[2] || t[1] == t[3] || t[2] == t[3])
      fail("tet slot " + std::to_string(slot) + " repeats a node");
    auto at = [&](std::uint32_t v) -> const Double3& {
      if (const std::ptrdiff_t j = moves ? lastMove(v) : -1; j >= 0) return movedRest[std::size_t(j)];
      return v < oldNodes ? d.mesh.restPositions[v] : rest[v - oldNodes];
    };
    const Double3 &a = at(t[0]), &b = at(t[1]), &cc = at(t[2]), &e = at(t[3]);
    const Double3 u{b.x - a.x, b.y - a.y, b.z - a.z}, v{cc.x - a.x, cc.y - a.y, cc.z - a.z}, w{e.x - a.x, e.y - a.y, e.z - a.z};
    const double vol = (u.x * (v.y * w.z - v.z * w.y) - u.y * (v.x * w.z - v.z * w.x) + u.z * (v.x * w.y - v.y * w.x)) / 6.0;
    if (!(vol > 0)) fail("tet slot " + std::to_string(slot) + " has a non-positive rest volume");
  }

  if (moves) {  // a moved node's tets change their rest shape: each must be rewritten
    std::vector<std::uint32_t> listed(c.tetSlots.begin(), c.tetSlots.end());
    std::sort(listed.begin(), listed.end());
    for (const auto& [node, k] : movedIndex) {
      if (node >= oldNodes) continue;  // a new node's tets are all new or rewritten
      const NodeIncidence& incidence = d.elements.incidence();
      for (const std::uint32_t* e = incidence.begin(node); e != incidence.end(node); ++e)
        if (!std::binary_search(listed.begin(), listed.end(), NodeIncidence::tetOf(*e)))
          fail("moved node " + std::to_string(node) + " has tet slot " + std::to_string(NodeIncidence::tetOf(*e)) +
               " not in the change");
    }
  }

  // Apply: only the touched nodes, slots, incidence rows and boundary faces are visited.
  d.elements.addNodes(c.newNodes.size());
  for (std::size_t k = 0; k < c.newNodes.size(); ++k) {
    d.mesh.restPositions.push_back(rest[k]);
    d.mesh.positions.push_back(pos[k]);
    d.velocity.push_back(vel[k]);
    d.fixed.push_back(fixedNew[k]);
    d.mass.push_back(0);
    d.nodeMark.push_back(0);
  }
  for (std::size_t k = 0; k < moves; ++k) {  // in order: a node moved twice ends at its last move
    const std::uint32_t v = c.movedNodes[k].node;
    d.mesh.restPositions[v] = movedRest[k];
    d.mesh.positions[v] = movedPos[k];
    d.velocity[v] = movedVel[k];
  }
  // Empty regions mean "all region 0": they are spelled out only once another region appears.
  if (d.mesh.regions.empty() && std::any_of(c.tetRegions.begin(), c.tetRegions.end(), [](std::uint32_t r) { return r != 0; }))
    d.mesh.regions.assign(d.mesh.tetCount(), 0);
  if (++d.markEpoch == 0) {  // wrapped: forget every old mark
    std::fill(d.nodeMark.begin(), d.nodeMark.end(), 0);
    d.markEpoch = 1;
  }
  d.touchedNodes.clear();  // nodes whose lumped mass changes, each once
  auto touch = [&d](const std::array<std::uint32_t, 4>& tet) {
    for (std::uint32_t v : tet)
      if (d.nodeMark[v] != d.markEpoch) {
        d.nodeMark[v] = d.markEpoch;
        d.touchedNodes.push_back(v);
      }
  };
  d.elements.appendSlots(tetCount - d.mesh.tetCount());  // tetCount: the count after the change
  d.overwrittenTets.clear();
  for (std::size_t k = 0; k < c.tetSlots.size(); ++k) {
    const std::uint32_t slot = c.tetSlots[k];
    if (slot == d.mesh.tetCount()) {
      d.mesh.tets.push_back(c.tetNodes[k]);
      if (!d.mesh.regions.empty()) d.mesh.regions.push_back(c.tetRegions[k]);
    } else {
      const auto& old = d.mesh.tets[slot];
      touch(old);
      d.overwrittenTets.push_back(old);
      d.mesh.tets[slot] = c.tetNodes[k];
      if (!d.mesh.regions.empty()) d.mesh.regions[slot] = c.tetRegions[k];
    }
    touch(c.tetNodes[k]);
    d.elements.setTet(slot, c.tetNodes[k], d.mesh.restPositions, d.settings.materials[c.tetRegions[k]]);
  }
  for (std::uint32_t v : d.touchedNodes) d.mass[v] = d.elements.lumpedMass(v);
  // Slots listed in increasing order (as cut events list them) are each written once; otherwise
  // the added faces include overwritten versions and every face is re-counted.
  const bool eachSlotOnce =
      std::adjacent_find(c.tetSlots.begin(), c.tetSlots.end(), [](std::uint32_t a, std::uint32_t b) { return a >= b; }) ==
      c.tetSlots.end();
  d.boundary.update(d.overwrittenTets, c.tetNodes, eachSlotOnce, std::uint32_t(oldNodes), d.elements.incidence(),
                    d.mesh.boundaryFaces);
  d.freeDof.resize(3 * nodes);
  for (std::size_t i = 3 * oldNodes; i < 3 * nodes; ++i) d.freeDof[i] = d.fixed[i / 3] ? 0 : 1;
  d.force.resize(3 * nodes, 0);
  d.nodeScale.resize(nodes, 0);
  d.diagonalBlocks.resize(6 * nodes, 0);
  d.patternDirty = true;  // the preconditioner's pattern is rebuilt at the next step
  // The solver matrix's rows of the nodes whose tets changed (new nodes included) are rebuilt
  // at the next step; the other rows keep their pattern.
  if (!d.matrixPatternDirty) {
    d.matrixRows.insert(d.matrixRows.end(), d.touchedNodes.begin(), d.touchedNodes.end());
    for (std::size_t v = oldNodes; v < nodes; ++v) d.matrixRows.push_back(std::uint32_t(v));
  }
  d.rhs.resize(3 * nodes, 0);
  d.solution.resize(3 * nodes, 0);
  for (std::size_t k = 0; k < c.newNodes.size(); ++k) {  // no history: the warm start is v
    d.previousVelocity.push_back(vel[k].x);
    d.previousVelocity.push_back(vel[k].y);
    d.previousVelocity.push_back(vel[k].z);
  }
  for (std::size_t k = 0; k < moves; ++k) {  // no history at the new place: the warm start is v
    const std::size_t v = c.movedNodes[k].node;
    d.previousVelocity[3 * v] = movedVel[k].x;
    d.previousVelocity[3 * v + 1] = movedVel[k].y;
    d.previousVelocity[3 * v + 2] = movedVel[k].z;
  }
  d.contactDepth.resize(nodes, 0);
  d.contactNormal.resize(nodes, {});
  d.embedded = false;  // the caller's render mesh no longer matches the cut body
  d.renderMesh = {};
  d.embedding = {};
}

void Simulation::run(int steps) {
  for (int i = 0; i < steps; ++i) step();
}

double Simulation::time() const { return impl_->time; }
const mesh::TetMesh& Simulation::mesh() const { return impl_->mesh; }
const std::vector<mesh::Double3>& Simulation::positions() const { return impl_->mesh.positions; }
const std::vector<mesh::Double3>& Simulation::velocities() const { return impl_->velocity; }
const std::vector<double>& Simulation::nodeMasses() const { return impl_->mass; }
const std::vector<unsigned char>& Simulation::fixedMask() const { return impl_->fixed; }
const SimulationSettings& Simulation::settings() const { return impl_->settings; }
const std::vector<ToolContactReport>& Simulation::toolContacts() const { return impl_->contacts; }
const StepStats& Simulation::lastStats() const { return impl_->stats; }
const SolverSummary& Simulation::solverSummary() const { return impl_->summary; }
void Simulation::setWarningHandler(std::function<void(const std::string&)> handler) {
  impl_->settings.onWarning = std::move(handler);
}

void Simulation::setPositions(const std::vector<mesh::Double3>& p) {
  if (p.size() != impl_->mesh.nodeCount()) throw std::invalid_argument("setPositions: wrong node count");
  impl_->mesh.positions = p;
}

void Simulation::setToolPoses(std::vector<ToolPose> poses) {
  if (!poses.empty() && poses.size() != impl_->settings.tools.size())
    throw std::invalid_argument("setToolPoses: " + std::to_string(poses.size()) + " poses for " +
                                std::to_string(impl_->settings.tools.size()) + " tools");
  impl_->toolPoses = std::move(poses);
}

std::vector<mesh::Double3> Simulation::previousVelocities() const {
  const auto& p = impl_->previousVelocity;
  std::vector<mesh::Double3> out(p.size() / 3);
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = {p[3 * i], p[3 * i + 1], p[3 * i + 2]};
  return out;
}

void Simulation::setPreviousVelocities(const std::vector<mesh::Double3>& v) {
  if (v.size() != impl_->mesh.nodeCount()) throw std::invalid_argument("setPreviousVelocities: wrong node count");
  for (std::size_t i = 0; i < v.size(); ++i) {
    impl_->previousVelocity[3 * i] = v[i].x;
    impl_->previousVelocity[3 * i + 1] = v[i].y;
    impl_->previousVelocity[3 * i + 2] = v[i].z;
  }
}

void Simulation::setFixed(const std::vector<std::uint32_t>& nodes, bool fixed) {
  Impl& d = *impl_;
  for (std::uint32_t i : nodes)
    if (i >= d.mesh.nodeCount()) throw std::invalid_argument("setFixed: node " + std::to_string(i) + " out of range");
  for (std::uint32_t i : nodes) {
    d.fixed[i] = fixed ? 1 : 0;
    for (int c = 0; c < 3; ++c) d.freeDof[3 * std::size_t(i) + std::size_t(c)] = fixed ? 0 : 1;
    if (fixed) d.velocity[i] = {};
  }
  d.factorDirty = true;
}

void Simulation::setVelocities(const std::vector<mesh::Double3>& v) {
  if (v.size() != impl_->mesh.nodeCount()) throw std::invalid_argument("setVelocities: wrong node count");
  impl_->velocity = v;
  for (std::size_t i = 0; i < v.size(); ++i) {  // a new state has no history: warm start from v
    impl_->previousVelocity[3 * i] = v[i].x;
    impl_->previousVelocity[3 * i + 1] = v[i].y;
    impl_->previousVelocity[3 * i + 2] = v[i].z;
  }
}

std::vector<mesh::Double3> Simulation::elasticForces() {
  Impl& d = *impl_;
  std::vector<double> f(3 * d.mesh.nodeCount(), 0.0);
  d.elements.computeForces(d.mesh.positions, d.settings.rotationMaxIterations, f.data(), nullptr);
  std::vector<mesh::Double3> out(d.mesh.nodeCount());
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = {f[3 * i], f[3 * i + 1], f[3 * i + 2]};
  return out;
}

Energies Simulation::energies() {
  Impl& d = *impl_;
  Energies e;
  std::vector<double> scratch(3 * d.mesh.nodeCount(), 0.0);
  e.elastic = d.elements.computeForces(d.mesh.positions, d.settings.rotationMaxIterations, scratch.data(), nullptr).energy;
  const auto& g = d.settings.gravity;
  for (std::size_t i = 0; i < d.mesh.nodeCount(); ++i) {
    const auto& v = d.velocity[i];
    const auto& p = d.mesh.positions[i];
    e.kinetic += 0.5 * d.mass[i] * (v.x * v.x + v.y * v.y + v.z * v.z);
    e.gravitational -= d.mass[i] * (g.x * p.x + g.y * p.y + g.z * p.z);
  }
  return e;
}

double Simulation::currentVolume() const { return totalVolume(impl_->mesh, false); }
double Simulation::restVolume() const { return totalVolume(impl_->mesh, true); }

void Simulation::setRenderSurface(mesh::TriMesh surface, SurfaceEmbedding embedding) {
  if (embedding.size() != surface.positions.size())
    throw std::invalid_argument("setRenderSurface: one embedding entry per surface vertex is needed");
  for (const auto& nodes : embedding.nodes)
    for (auto n : nodes)
      if (n >= impl_->mesh.nodeCount()) throw std::invalid_argument("setRenderSurface: embedding references a missing node");
  impl_->renderMesh = std::move(surface);
  impl_->embedding = std::move(embedding);
  impl_->embedded = true;
}

mesh::TriMesh Simulation::renderSurface() const {
  const Impl& d = *impl_;
  if (!d.embedded) return boundarySurface(d.mesh);
  mesh::TriMesh s = d.renderMesh;
  applyEmbedding(d.embedding, d.mesh.positions, s);
  return s;
}

}  // namespace blobvk::fem
