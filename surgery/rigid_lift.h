// The scripted lift of a part that cutting has freed (a bone flap, an egg's cap): its nodes are
// pinned in the FEM and carried rigidly along the scene's path. See LiftConfig.
#pragma once

#include "blobvk/surgery/scene_config.h"

#include "blobvk/fem/simulation.h"
#include "blobvk/fem/tool.h"

#include <cstdint>
#include <string>
#include <vector>

namespace blobvk::surgery {

class RigidLift {
 public:
  explicit RigidLift(const LiftConfig& config);

  // Starts the lift at `time` when the part (tet lists, e.g. cutting::disjointParts) nearest the
  // configured point holds no fixed node; returns whether it started. Nothing happens before
  // the configured start time.
  bool tryStart(double time, const std::vector<std::vector<std::uint32_t>>& parts, fem::Simulation& sim);
  // Why the lift has not started, for the run's summary: the nearest part's size and fixed nodes.
  std::string waitingReason(const std::vector<std::vector<std::uint32_t>>& parts, const fem::Simulation& sim) const;
  // Places the lifted nodes where the path has them at `time` (call before the step to `time`).
  void drive(double time, fem::Simulation& sim) const;

  bool started() const { return startTime_ >= 0; }
  double startTime() const { return startTime_; }
  double earliestStart() const { return earliest_; }
  std::size_t nodeCount() const { return nodes_.size(); }
  std::size_t tetCount() const { return tets_; }
  // Distance of the lifted nodes' centroid from their rest centroid (0 before the start).
  double distanceFromRest(const fem::Simulation& sim) const;
  // The distance the path's last keyframe carries the part's centroid (translation only).
  double pathDistance() const;

 private:
  // The part holding the tet whose centroid is nearest the configured point, and its nodes.
  std::size_t nearestPart(const std::vector<std::vector<std::uint32_t>>& parts, const fem::Simulation& sim) const;
  static std::vector<std::uint32_t> nodesOf(const std::vector<std::uint32_t>& tets, const fem::Simulation& sim);

  mesh::Double3 near_;
  double earliest_ = 0;
  fem::Tool path_;  // a tool's keyframes interpolate the rigid motion (lerp + normalized lerp)
  std::vector<std::uint32_t> nodes_;
  std::vector<mesh::Double3> atStart_;
  mesh::Double3 pivot_;
  std::size_t tets_ = 0;
  double startTime_ = -1;
};

}  // namespace blobvk::surgery
