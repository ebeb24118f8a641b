// A scene's scripted procedure, one client of SoftBody: the blade follows its keyframes
// (simulation times), the tools their paths, and the scripted lift (if any) carries a part
// that cutting has freed. Each step hands SoftBody the blade positions inside the step.
#pragma once

#include "blobvk/surgery/rigid_lift.h"
#include "blobvk/surgery/scene_config.h"
#include "blobvk/surgery/soft_body.h"

#include "blobvk/cutting/blade.h"

#include <optional>
#include <vector>

namespace blobvk::surgery {

class ScriptedProcedure {
 public:
  // `blade` keyframe times are simulation times (strictly increasing; fewer than 2: no cut).
  // Throws std::invalid_argument for keyframe times that do not increase.
  ScriptedProcedure(mesh::TetMesh tets, const SimulationConfig& config, const std::vector<BladeKeyframe>& blade,
                    SoftBodyOptions options = {});

  // One time step: the blade's positions in the step (split at its keyframes), the lift, the
  // tools at their paths; see SoftBody::step.
  void step();

  SoftBody& body() { return body_; }
  const SoftBody& body() const { return body_; }
  const fem::Simulation& simulation() const { return body_.simulation(); }
  const RigidLift* lift() const { return lift_ ? &*lift_ : nullptr; }
  bool cuttingDone() const { return strokeFinished_; }

 private:
  SoftBody body_;
  cutting::BladePath blade_;
  std::optional<RigidLift> lift_;
  bool strokeFinished_ = false;
};

}  // namespace blobvk::surgery
