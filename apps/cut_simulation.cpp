#include "cut_simulation.h"

#include "cut_to_topology_change.h"

#include "blobvk/cutting/parts.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <string>

namespace blobvk::app {
namespace {

double msSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

cutting::BladePath bladePath(const std::vector<BladeKeyframe>& keys) {
  cutting::BladePath path;
  for (std::size_t i = 0; i < keys.size(); ++i) {
    if (i > 0 && !(keys[i].time > keys[i - 1].time))
      throw std::invalid_argument("blade keyframe " + std::to_string(i) + ": times must increase strictly (they are simulation times)");
    path.keyframes.push_back({keys[i].time, keys[i].a, keys[i].b});
  }
  return path;
}

// A body that will be cut gets spare room for the cuts' new nodes and tets up front.
fem::SimulationSettings withCutRoom(fem::SimulationSettings settings) {
  if (settings.cutRoom <= 0) settings.cutRoom = 0.5;
  return settings;
}

}  // namespace

CutSimulation::CutSimulation(mesh::TetMesh tets, const SimulationConfig& config, const std::vector<BladeKeyframe>& blade,
                             CutSimulationOptions options)
    : sim_(tets, withCutRoom(config.settings)), blade_(bladePath(blade)), options_(options) {
  cutter_ = std::make_unique<cutting::Cutter>(std::move(tets));
  if (config.lift) lift_.emplace(*config.lift);
  parts_ = cutting::disjointParts(cutter_->topology());
  strokeFinished_ = blade_.keyframes.size() < 2;
}

void CutSimulation::setRenderSurface(mesh::TriMesh surface, fem::SurfaceEmbedding embedding) {
  sim_.setRenderSurface(std::move(surface), std::move(embedding));
}

// The blade's swept surface between two times: one quad per keyframe interval it crosses.
std::vector<cutting::Triangle> CutSimulation::sweepBetween(double from, double to) const {
  std::vector<cutting::Triangle> out;
  const auto& k = blade_.keyframes;
  if (k.size() < 2) return out;
  from = std::max(from, k.front().time);
  to = std::min(to, k.back().time);
  if (!(to > from)) return out;
  cutting::BladeKeyframe previous = cutting::bladeAt(blade_, from);
  auto add = [&](const cutting::BladeKeyframe& next) {
    const auto tris = cutting::sweptTriangles(previous, next);
    out.insert(out.end(), tris.begin(), tris.end());
    previous = next;
  };
  for (const cutting::BladeKeyframe& key : k)
    if (key.time > from && key.time < to) add(key);
  add(cutting::bladeAt(blade_, to));
  return out;
}

void CutSimulation::cutEvent(const std::vector<cutting::Triangle>& swept) {
  const std::size_t nodesBefore = sim_.mesh().nodeCount(), tetsBefore = sim_.mesh().tetCount();
  auto start = std::chrono::steady_clock::now();
  const cutting::CutResult event = cutter_->cut(swept);
  cutMs_ += msSince(start);
  ++events_;
  if (event.addedTets.empty() && event.newNodes.empty()) return;
  start = std::chrono::steady_clock::now();
  sim_.applyTopologyChange(toTopologyChange(event, cutter_->topology(), nodesBefore, tetsBefore));
  updateMs_ += msSince(start);
  splitTets_ += event.splitTets;
  partsChanged_ = true;
  if (options_.checkEachEvent) {
    const cutting::SelfCheckReport check = cutter_->topology().selfCheck();
    if (!check.ok()) throw std::runtime_error("cut event " + std::to_string(events_) + " failed the topology self-check: " + check.summary());
    ++checksPassed_;
  }
}

void CutSimulation::step() {
  const double t0 = sim_.time(), h = sim_.settings().timeStep, t1 = t0 + h;
  const auto cutStart = std::chrono::steady_clock::now();
  lastCutMs_ = 0;
  if (!strokeFinished_) {
    // One event per blade interval inside the step: the step is split at keyframe times, so a
    // blade faster than the time step cuts exactly the events of cutting::runBladePath (one per
    // keyframe interval, each re-sweeping the one before), and a slower one cuts once per step.
    const auto& keys = blade_.keyframes;
    std::vector<double> cuts{std::max(t0, keys.front().time)};
    for (const auto& key : keys)
      if (key.time > cuts.front() && key.time < t1) cuts.push_back(key.time);
    cuts.push_back(std::min(t1, keys.back().time));
    bool synced = false;
    for (std::size_t i = 1; i < cuts.size(); ++i) {
      std::vector<cutting::Triangle> swept = sweepBetween(cuts[i - 1], cuts[i]);
      if (swept.empty()) continue;
      if (!synced) {  // the blade cuts the body where it is now
        auto& positions = cutter_->topology().positions();
        std::copy(sim_.positions().begin(), sim_.positions().end(), positions.begin());
        cutter_->positionsChanged();
        synced = true;
      }
      if (options_.resweepPreviousStep && previousSweep_[1] > previousSweep_[0]) {
        const auto previous = sweepBetween(previousSweep_[0], previousSweep_[1]);
        swept.insert(swept.end(), previous.begin(), previous.end());
      }
      previousSweep_ = {cuts[i - 1], cuts[i]};
      cutEvent(swept);
    }
    if (t1 >= blade_.keyframes.back().time) {
      // The stroke is over: sweep all of it again to finish the seams where it closes or bends.
      const auto stroke = sweepBetween(blade_.keyframes.front().time, blade_.keyframes.back().time);
      for (int pass = 0; pass < options_.finalStrokePasses && blade_.keyframes.size() > 2; ++pass) {
        const std::size_t before = splitTets_;
        cutEvent(stroke);
        if (splitTets_ == before) break;
      }
      strokeFinished_ = true;
    }
    lastCutMs_ = msSince(cutStart);
  }
  if (partsChanged_) {
    parts_ = cutting::disjointParts(cutter_->topology());
    partsChanged_ = false;
  }
  // The lift waits for the cut to be complete, so no later event splits the part it carries.
  if (lift_ && strokeFinished_ && !lift_->started()) lift_->tryStart(t0, parts_, sim_);
  if (lift_) lift_->drive(t1, sim_);

  sim_.step();
  lastFemMs_ = sim_.lastStats().totalMs;
  for (const auto& x : sim_.positions())
    if (!std::isfinite(x.x) || !std::isfinite(x.y) || !std::isfinite(x.z))
      throw std::runtime_error("the simulation diverged at t = " + std::to_string(sim_.time()) + " (NaN)");
}

}  // namespace blobvk::app
