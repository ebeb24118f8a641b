// `blobvk cut` as one simulation: every time step the blade's swept surface over [t, t+h] is cut
// into the moving body (cutting::Cutter, its positions synced from the FEM), each cut event is
// applied to the running FEM (Simulation::applyTopologyChange), then the scripted lift (if any)
// drives a freed part and the FEM steps. Tools act throughout.
#pragma once

#include "rigid_lift.h"
#include "simulation_config.h"

#include "blobvk/cutting/blade.h"
#include "blobvk/cutting/cutter.h"
#include "blobvk/fem/simulation.h"

#include <array>
#include <memory>
#include <optional>
#include <vector>

namespace blobvk::app {

struct CutSimulationOptions {
  // As cutting::runBladePath: each event also re-sweeps the previous step, so tets the blade
  // stopped inside (partial cases C, D, E) are finished; after the blade's last keyframe the
  // whole stroke is swept again up to finalStrokePasses times, until nothing splits.
  bool resweepPreviousStep = true;
  int finalStrokePasses = 2;
  bool checkEachEvent = false;  // O(n) topology self-check after every event; throws on failure
};

class CutSimulation {
 public:
  // `blade` keyframe times are simulation times (strictly increasing; may be empty: no cut).
  CutSimulation(mesh::TetMesh tets, const SimulationConfig& config, const std::vector<BladeKeyframe>& blade,
                CutSimulationOptions options = {});
  void setRenderSurface(mesh::TriMesh surface, fem::SurfaceEmbedding embedding);

  // One time step: cut, lift, FEM step. Throws when the FEM produces a NaN.
  void step();

  const fem::Simulation& simulation() const { return sim_; }
  const cutting::CutTopology& topology() const { return cutter_->topology(); }
  const RigidLift* lift() const { return lift_ ? &*lift_ : nullptr; }
  bool cuttingDone() const { return strokeFinished_; }

  std::size_t events() const { return events_; }
  std::size_t splitTets() const { return splitTets_; }
  std::size_t partCount() const { return parts_.size(); }
  const std::vector<std::vector<std::uint32_t>>& parts() const { return parts_; }  // tet slots, largest first
  std::size_t checksPassed() const { return checksPassed_; }
  double cutMs() const { return cutMs_; }        // Cutter::cut, all events
  double updateMs() const { return updateMs_; }  // conversion + Simulation::applyTopologyChange
  double lastStepCutMs() const { return lastCutMs_; }  // cut + update in the last step
  double lastStepFemMs() const { return lastFemMs_; }

 private:
  void cutEvent(const std::vector<cutting::Triangle>& swept);
  std::vector<cutting::Triangle> sweepBetween(double from, double to) const;

  fem::Simulation sim_;
  std::unique_ptr<cutting::Cutter> cutter_;
  cutting::BladePath blade_;
  CutSimulationOptions options_;
  std::optional<RigidLift> lift_;
  std::vector<std::vector<std::uint32_t>> parts_;
  std::array<double, 2> previousSweep_{0, 0};  // the blade interval of the last event
  bool partsChanged_ = false, strokeFinished_ = false;
  std::size_t events_ = 0, splitTets_ = 0, checksPassed_ = 0;
  double cutMs_ = 0, updateMs_ = 0, lastCutMs_ = 0, lastFemMs_ = 0;
};

}  // namespace blobvk::app
