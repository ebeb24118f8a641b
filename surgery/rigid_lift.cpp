#include "blobvk/surgery/rigid_lift.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace blobvk::surgery {
namespace {

using mesh::Double3;

double distance2(const Double3& a, const Double3& b) {
  return (a.x - b.x) * (a.x - b.x) + (a.y - b.y) * (a.y - b.y) + (a.z - b.z) * (a.z - b.z);
}

Double3 centroid(const std::vector<Double3>& all, const std::vector<std::uint32_t>& nodes) {
  Double3 c{0, 0, 0};
  for (std::uint32_t v : nodes) c = {c.x + all[v].x, c.y + all[v].y, c.z + all[v].z};
  const double n = double(std::max<std::size_t>(1, nodes.size()));
  return {c.x / n, c.y / n, c.z / n};
}

}  // namespace

RigidLift::RigidLift(const LiftConfig& config) : near_(config.near), earliest_(config.start) {
  for (const LiftKeyframe& k : config.path) path_.path.push_back({k.time, k.translation, k.rotation});
}

std::size_t RigidLift::nearestPart(const std::vector<std::vector<std::uint32_t>>& parts, const fem::Simulation& sim) const {
  const mesh::TetMesh& mesh = sim.mesh();
  std::size_t best = 0;
  double bestDistance = std::numeric_limits<double>::infinity();
  for (std::size_t p = 0; p < parts.size(); ++p) {
    for (std::uint32_t slot : parts[p]) {
      Double3 c{0, 0, 0};
      for (std::uint32_t v : mesh.tets[slot]) c = {c.x + 0.25 * mesh.positions[v].x, c.y + 0.25 * mesh.positions[v].y, c.z + 0.25 * mesh.positions[v].z};
      const double d = distance2(c, near_);
      if (d < bestDistance) bestDistance = d, best = p;
    }
  }
  return best;
}

std::vector<std::uint32_t> RigidLift::nodesOf(const std::vector<std::uint32_t>& tets, const fem::Simulation& sim) {
  std::vector<std::uint32_t> nodes;
  for (std::uint32_t slot : tets) nodes.insert(nodes.end(), sim.mesh().tets[slot].begin(), sim.mesh().tets[slot].end());
  std::sort(nodes.begin(), nodes.end());
  nodes.erase(std::unique(nodes.begin(), nodes.end()), nodes.end());
  return nodes;
}

std::string RigidLift::waitingReason(const std::vector<std::vector<std::uint32_t>>& parts, const fem::Simulation& sim) const {
  if (parts.empty()) return "no parts";
  const std::size_t p = nearestPart(parts, sim);
  const auto nodes = nodesOf(parts[p], sim);
  std::size_t fixed = 0;
  for (std::uint32_t v : nodes) fixed += sim.fixedMask()[v] != 0;
  return "the part nearest the lift point (" + std::to_string(parts[p].size()) + " tets of " + std::to_string(sim.mesh().tetCount()) +
         ", one of " + std::to_string(parts.size()) + " parts) holds " + std::to_string(fixed) + " fixed nodes";
}

bool RigidLift::tryStart(double time, const std::vector<std::vector<std::uint32_t>>& parts, fem::Simulation& sim) {
  if (started() || time < earliest_ || parts.size() < 2) return false;
  const mesh::TetMesh& mesh = sim.mesh();
  const std::size_t best = nearestPart(parts, sim);
  std::vector<std::uint32_t> nodes = nodesOf(parts[best], sim);
  const auto& fixed = sim.fixedMask();
  // Still held (by the clamp, or through tissue not yet cut): not free to lift.
  if (std::any_of(nodes.begin(), nodes.end(), [&](std::uint32_t v) { return fixed[v] != 0; })) return false;
  nodes_ = std::move(nodes);
  tets_ = parts[best].size();
  atStart_.clear();
  for (std::uint32_t v : nodes_) atStart_.push_back(mesh.positions[v]);
  pivot_ = centroid(mesh.positions, nodes_);
  startTime_ = time;
  sim.setFixed(nodes_, true);
  return true;
}

void RigidLift::drive(double time, fem::Simulation& sim) const {
  if (!started()) return;
  const fem::ToolPose pose = path_.poseAt(time - startTime_);
  const auto& R = pose.rotation;
  std::vector<Double3> positions = sim.positions();
  for (std::size_t i = 0; i < nodes_.size(); ++i) {
    const Double3 d{atStart_[i].x - pivot_.x, atStart_[i].y - pivot_.y, atStart_[i].z - pivot_.z};
    positions[nodes_[i]] = {pivot_.x + R[0] * d.x + R[1] * d.y + R[2] * d.z + pose.position.x,
                            pivot_.y + R[3] * d.x + R[4] * d.y + R[5] * d.z + pose.position.y,
                            pivot_.z + R[6] * d.x + R[7] * d.y + R[8] * d.z + pose.position.z};
  }
  sim.setPositions(positions);
}

double RigidLift::distanceFromRest(const fem::Simulation& sim) const {
  if (!started()) return 0;
  return std::sqrt(distance2(centroid(sim.positions(), nodes_), centroid(sim.mesh().restPositions, nodes_)));
}

double RigidLift::pathDistance() const {
  const Double3& t = path_.path.back().position;
  return std::sqrt(t.x * t.x + t.y * t.y + t.z * t.z);
}

}  // namespace blobvk::surgery
