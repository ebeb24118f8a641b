// A cuttable soft body stepped with tool and blade poses given at run time: the surgical
// pipeline's core. Each step (1) cuts where the blade passed through the material, (2) applies
// every cut event to the running FEM, (3) finds the parts and applies the fragment policy,
// (4) steps the FEM with the given tool poses. Cuts are made in material (rest) coordinates:
// each blade position is mapped back through the deformed tets into the rest configuration,
// so the swept surface of a stroke is one fixed surface of the material however the body
// moves, consecutive steps join exactly and the stroke can be swept again to finish its seams.
#pragma once

#include "blobvk/cutting/cutter.h"
#include "blobvk/fem/simulation.h"
#include "blobvk/fem/surface_embedding.h"
#include "blobvk/fem/tool.h"
#include "blobvk/mesh/tetmesh.h"

#include <cstdint>
#include <memory>
#include <vector>

namespace blobvk::surgery {

// The blade's cutting edge, a segment in world coordinates.
struct BladeSegment {
  mesh::Double3 a, b;
};

struct StepInput {
  // One pose per tool of the settings; empty: the tools follow their keyframed paths.
  std::vector<fem::ToolPose> tools;
  // The blade's positions during this step, in order, against the body as it is at the step's
  // start (a fast blade passes several). Empty: the blade is not in the body, and a stroke in
  // progress ends.
  std::vector<BladeSegment> blade;
  // The stroke ends after this step's positions: its whole surface is cut again (up to
  // SoftBodyOptions::finalStrokePasses times) to finish tets it left partly cut.
  bool endStroke = false;
};

// Parts much smaller than the body (chips a cut leaves, 1-3 tets) are fragments.
struct FragmentPolicy {
  enum class Action { Keep, Remove };
  Action action = Action::Remove;
  // A part other than the largest is a fragment when it holds at most this many tets ...
  std::size_t maxTets = 0;
  // ... or at most this fraction of the body's tets.
  double maxFraction = 0.002;
};

struct FragmentReport {
  double time = 0;         // when it was found
  std::size_t tets = 0;
  bool removed = false;
};

struct SoftBodyOptions {
  cutting::CutOptions cut;
  FragmentPolicy fragments;
  bool resweepPreviousStep = true;  // each event also cuts the previous blade interval again
  int finalStrokePasses = 2;        // see StepInput::endStroke
  // The blade is mapped into material coordinates at its two ends (1) or at the ends of this
  // many equal segments along it. More segments follow a body bent across the blade more
  // closely; on the TetGen craniotomy at rest 1, 2 and 4 free the same flap (docs/surgery.md).
  int bladeSegments = 1;
  bool checkEachEvent = false;      // O(n) topology self-check after every event; throws on failure
  // Spare FEM room for cut nodes and tets (fem::SimulationSettings::cutRoom), when the settings
  // give none.
  double cutRoom = 0.5;
};

class SoftBody {
 public:
  // `tets` at rest (positions = rest positions). Throws what fem::Simulation throws.
  SoftBody(mesh::TetMesh tets, fem::SimulationSettings settings, SoftBodyOptions options = {});
  ~SoftBody();
  SoftBody(SoftBody&&) noexcept;
  SoftBody& operator=(SoftBody&&) noexcept;

  // The render surface until the first cut (then the tet boundary, crack faces included).
  void setRenderSurface(mesh::TriMesh surface, fem::SurfaceEmbedding embedding);

  // One time step (cut, parts and fragments, FEM). Throws std::runtime_error when the FEM
  // diverges (a NaN) or a checked event fails the self-check.
  void step(const StepInput& input);

  // Resection: removes the given tets (slots of mesh(), each live) and lets the FEM go on with
  // the rest, keeping positions, velocities and fixed nodes. Nodes left without a tet are kept
  // (indices never change) and fixed. Tet slots are renumbered: parts() afterwards.
  void resect(const std::vector<std::uint32_t>& slots);

  fem::Simulation& simulation() { return *sim_; }
  const fem::Simulation& simulation() const { return *sim_; }
  const mesh::TetMesh& mesh() const { return sim_->mesh(); }
  const cutting::CutTopology& topology() const { return cutter_->topology(); }
  double time() const;  // simulated seconds since construction

  // Live tets grouped by face connectivity, largest first (tet slots of mesh()).
  const std::vector<std::vector<std::uint32_t>>& parts() const { return parts_; }
  // The fragments removed so far, then those kept now (a kept one is reported once however many
  // events follow; its time is that of the last parts update).
  std::vector<FragmentReport> fragments() const;
  bool strokeInProgress() const { return !strokePolyline_.empty(); }

  std::size_t events() const { return events_; }
  std::size_t splitTets() const { return splitTets_; }
  std::size_t checksPassed() const { return checksPassed_; }
  double cutMs() const { return cutMs_; }        // blade mapping + Cutter::cut, all events
  double updateMs() const { return updateMs_; }  // cut -> FEM conversion and update, resections
  double lastStepCutMs() const { return lastCutMs_; }
  double lastStepFemMs() const { return lastFemMs_; }

 private:
  void cutBlade(const std::vector<BladeSegment>& blade);
  void finishStroke();
  void cutEvent(const std::vector<cutting::Triangle>& swept);
  void updateParts();

  std::unique_ptr<fem::Simulation> sim_;
  std::unique_ptr<cutting::Cutter> cutter_;
  fem::SimulationSettings settings_;
  SoftBodyOptions options_;
  double meanEdge_ = 0, timeOffset_ = 0;
  std::vector<mesh::Double3> strokePolyline_;       // the blade's last position, in material coordinates
  std::vector<cutting::Triangle> stroke_, previous_;  // the stroke's swept surface and its last interval
  std::vector<std::vector<std::uint32_t>> parts_;
  std::vector<FragmentReport> removedFragments_, keptFragments_;
  bool partsChanged_ = false;
  std::size_t events_ = 0, splitTets_ = 0, checksPassed_ = 0;
  double cutMs_ = 0, updateMs_ = 0, lastCutMs_ = 0, lastFemMs_ = 0;
};

}  // namespace blobvk::surgery
