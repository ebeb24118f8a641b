// Soft-body simulation of a tet mesh: corotational linear FEM, lumped mass, Rayleigh damping,
// implicit backward Euler (one linearised Newton step per time step, Baraff-Witkin), solved
// with warm-started PCG on the matrix-free warped stiffness (preconditioners below); fixed nodes, gravity, a floor
// plane and penalty contact with moving implicit tools. Eigen and TBB stay in the .cpp files.
#pragma once

#include "blobvk/fem/material.h"
#include "blobvk/fem/surface_embedding.h"
#include "blobvk/fem/tool.h"
#include "blobvk/mesh/tetmesh.h"
#include "blobvk/mesh/trimesh.h"

#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace blobvk::fem {

// The floor: nodes are kept on the side where dot(normal, x) >= offset. A node that crosses it
// is projected back; its normal velocity becomes -restitution * v_n and its tangential velocity
// is scaled by (1 - friction).
struct FloorPlane {
  mesh::Double3 normal{0, 1, 0};
  double offset = 0;
  double restitution = 0.0;
  double friction = 0.5;
};

// true for nodes that must not move, given their rest position (e.g. an implicit selector).
using NodeSelector = std::function<bool(const mesh::Double3& restPosition)>;

// How the implicit system's CG is preconditioned. Jacobi: A's diagonal. BlockJacobi: A's 3x3
// node blocks. IncompleteCholesky: an incomplete Cholesky factor of the assembled A (Eigen,
// AMD ordering), rebuilt every `preconditionerRefreshSteps` steps, when the solve gets slow
// (twice the iterations of the solve right after the last build, plus 5), or after a topology or
// fixed-set change; between rebuilds, an older factor still preconditions (any SPD P does).
enum class PreconditionerKind { Jacobi, BlockJacobi, IncompleteCholesky };

struct SimulationSettings {
  std::vector<Material> materials = std::vector<Material>(1);  // indexed by TetMesh::regions (region 0 if empty)
  double timeStep = 1.0 / 60.0;
  mesh::Double3 gravity{0, -9.81, 0};
  double rayleighMass = 0.0;        // alpha: D = alpha M + beta K
  double rayleighStiffness = 0.01;  // beta (seconds)
  int cgMaxIterations = 500;
  double cgTolerance = 1e-3;        // relative residual |r| / |b|; 0 = always cgMaxIterations
  PreconditionerKind preconditioner = PreconditionerKind::BlockJacobi;
  int preconditionerRefreshSteps = 10;
  // Jacobi / block-Jacobi: nodes per aggregate of the two-level correction (coarse_correction.h:
  // the system restricted to aggregate translations, solved exactly each step); 0 = off.
  int coarseAggregateNodes = 125;
  // Called with one line the first time a step's CG stops at cgMaxIterations above the
  // tolerance (later such steps are counted in solverSummary(), not reported again). The library
  // prints nothing itself.
  std::function<void(const std::string& line)> onWarning;
  int rotationMaxIterations = 30;
  NodeSelector fixed;                      // optional
  std::vector<std::uint32_t> fixedNodes;   // optional, added to the selector's nodes
  std::optional<FloorPlane> floor;
  std::vector<Tool> tools;
  // Spare room for topology changes (cuts), as a fraction of the node and tet counts, reserved
  // and written once at construction so that applyTopologyChange neither reallocates every
  // array nor takes page faults mid-event. 0 (the default) for bodies that are never cut: the
  // room costs memory and construction time (100k tets, 0.5: +25 MB, construction 28 -> ~50 ms).
  // `blobvk cut` uses 0.5 (~25 cut events at 100k tets before an array must grow).
  double cutRoom = 0.0;
};

// Per-phase wall times of the last step. "rotations" is the fused per-tet pass (rotations,
// stresses, forces per corner); "assembly" the per-node gather of forces, mass and gravity
// terms and the assembly of the system matrix, including "matrixPatternMs": building its
// pattern (first step) or rebuilding the rows a topology change touched (the step after it).
// "preconditionerMs" is the preconditioner's set-up (factorization on the steps that rebuild
// it); "solveMs" the CG iterations and the update, without the set-up.
struct StepStats {
  double rotationsMs = 0, assemblyMs = 0, contactMs = 0, preconditionerMs = 0, solveMs = 0, totalMs = 0;
  double matrixPatternMs = 0;
  int cgIterations = 0;
  double cgRelativeResidual = 0;  // |b - A v| / |b| over free DOFs at the end of the solve
  bool cgConverged = true;        // the tolerance was met (false: stopped at cgMaxIterations)
  bool preconditionerRebuilt = false;
  double rotationIterationsPerTet = 0;
};

// The solver over all steps so far.
struct SolverSummary {
  long long steps = 0, iterations = 0;  // iterations: total over the steps
  long long capHits = 0;                // steps that stopped at cgMaxIterations above the tolerance
  int maxIterations = 0;
  double maxRelativeResidual = 0;  // NaN once a step's residual was NaN (a solve that broke down)
  long long preconditionerBuilds = 0;
};

// The larger residual, where a NaN is the largest: a broken-down solve must show in a maximum
// (std::max(x, NaN) is x).
inline double worseResidual(double a, double b) { return std::isnan(a) || std::isnan(b) ? a + b : (a < b ? b : a); }

// What tool k did to the body in the last step.
struct ToolContactReport {
  std::size_t nodesInContact = 0;
  mesh::Double3 force;     // total penalty force on the body (the tool feels the opposite)
  double maxDepth = 0;     // deepest penetration of a node inside the iso surface
};

// Where a node added by a topology change comes from: its rest position, position and velocity
// are sum(weights[i] * value(sources[i])) over the used entries (unused sources are kNoSource).
// A node duplicated by a crack has one source with weight 1.
inline constexpr std::uint32_t kNoSource = 0xffffffffu;
struct NodeOrigin {
  std::array<std::uint32_t, 4> sources{kNoSource, kNoSource, kNoSource, kNoSource};
  std::array<double, 4> weights{};
};

// A local change of the mesh, as one cut event makes it (`cutting::CutResult` converts to it):
// `newNodes` are appended in order (existing node indices never change); slot `tetSlots[k]`
// becomes `tetNodes[k]` with material region `tetRegions[k]` — an existing slot rewritten in
// place, or the next slot past the current end. A new node is fixed when the fixed selector
// picks its rest position or all its sources are fixed.
// `movedNodes` (a cut's node smoothing) change the rest shape: each node's rest position,
// position and velocity become its origin's weighted sum of the values just before that move
// (applied after newNodes, in list order); every tet around a moved node must be in tetSlots.
struct NodeMove {
  std::uint32_t node = 0;
  NodeOrigin origin;
};
struct TopologyChange {
  std::vector<NodeOrigin> newNodes;
  std::vector<NodeMove> movedNodes;
  std::vector<std::uint32_t> tetSlots;
  std::vector<std::array<std::uint32_t, 4>> tetNodes;
  std::vector<std::uint32_t> tetRegions;
};

struct Energies {
  double kinetic = 0, elastic = 0, gravitational = 0;  // gravitational = -sum m g.x
  double total() const { return kinetic + elastic + gravitational; }
};

class Simulation {
 public:
  // Validates mesh (degenerate tets, indices), materials (E > 0, -1 < nu < 0.5, rho > 0), region
  // indices, tools and time step; throws std::invalid_argument with the reason. Given boundary
  // faces are kept, sorted into findBoundaryFaces order; none given: they are computed.
  Simulation(mesh::TetMesh mesh, SimulationSettings settings);
  ~Simulation();
  Simulation(Simulation&&) noexcept;
  Simulation& operator=(Simulation&&) noexcept;

  void step();
  void run(int steps);

  // Applies a topology change (a cut) to the running simulation, keeping its state: validates
  // the change (indices, positive rest volumes, materials; throws std::invalid_argument with the
  // reason and changes nothing) and updates the element data, masses, node incidence and
  // boundary faces of what it touched only: the cost grows with the change, not with the mesh.
  // mesh().boundaryFaces is edited in place (kept in findBoundaryFaces order); when faces appear
  // or vanish that is one block-copy pass over the list (~200 KB with its keys at 8.5k faces), the only
  // O(surface) part. Boundary tracking relies on the mesh staying conforming (a face shared by at
  // most two tets), as meshers and cuts keep it. Untouched tets keep their rotation warm start.
  // The result equals a fresh Simulation on the changed mesh with the same state. The render
  // surface becomes the new tet boundary (a caller embedding is dropped); renderSurface() builds
  // it on request, O(nodes + boundary faces).
  void applyTopologyChange(const TopologyChange& change);

  double time() const;
  const mesh::TetMesh& mesh() const;                  // positions are the current state
  const std::vector<mesh::Double3>& positions() const;
  const std::vector<mesh::Double3>& velocities() const;
  void setPositions(const std::vector<mesh::Double3>& positions);
  void setVelocities(const std::vector<mesh::Double3>& velocities);
  // The velocity one step back: the solver's warm start extrapolates from it and the current
  // one (setVelocities resets it to the new velocity). Part of the state a copy must carry.
  std::vector<mesh::Double3> previousVelocities() const;
  void setPreviousVelocities(const std::vector<mesh::Double3>& velocities);
  const std::vector<double>& nodeMasses() const;
  const std::vector<unsigned char>& fixedMask() const;  // 1 per fixed node
  // Pins (fixed = true) or releases nodes after construction. A pinned node is not moved by the
  // solver and keeps what setPositions gives it, so a caller can drive it along a scripted path
  // (e.g. a bone flap lifted away by a grasping tool); its velocity is set to zero.
  void setFixed(const std::vector<std::uint32_t>& nodes, bool fixed);
  const SimulationSettings& settings() const;

  // Elastic forces at the current positions (3 per node; rotations re-extracted first).
  std::vector<mesh::Double3> elasticForces();
  Energies energies();
  double currentVolume() const;
  double restVolume() const;

  // Poses of the tools for the following steps, one per tool, in place of their keyframed paths
  // (a host application or a haptic device drives them); an empty vector returns the tools to
  // their paths. Throws std::invalid_argument when the count differs from the tools'.
  void setToolPoses(std::vector<ToolPose> poses);
  const std::vector<ToolContactReport>& toolContacts() const;  // one per tool, last step
  const StepStats& lastStats() const;
  const SolverSummary& solverSummary() const;
  // Replaces SimulationSettings::onWarning (e.g. a CLI that prints the line to stderr).
  void setWarningHandler(std::function<void(const std::string& line)> handler);

  // Render surface: by default the tet boundary; or a caller mesh embedded in the tets.
  void setRenderSurface(mesh::TriMesh surface, SurfaceEmbedding embedding);
  mesh::TriMesh renderSurface() const;  // positions follow the body, normals recomputed

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace blobvk::fem
