#include "blobvk/surgery/soft_body.h"

#include "blobvk/cutting/parts.h"
#include "blobvk/surgery/cut_to_topology_change.h"
#include "blobvk/surgery/material_map.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <string>

namespace blobvk::surgery {
namespace {

using mesh::Double3;

double msSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

double distance(const Double3& a, const Double3& b) {
  return std::sqrt((a.x - b.x) * (a.x - b.x) + (a.y - b.y) * (a.y - b.y) + (a.z - b.z) * (a.z - b.z));
}

double meanRestEdge(const mesh::TetMesh& m) {
  double sum = 0;
  for (const auto& t : m.tets)
    for (int i = 0; i < 4; ++i)
      for (int j = i + 1; j < 4; ++j) sum += distance(m.restPositions[t[std::size_t(i)]], m.restPositions[t[std::size_t(j)]]);
  return m.tets.empty() ? 1.0 : sum / (6.0 * double(m.tets.size()));
}

// The cutter works on the rest configuration: its positions are the rest positions, always.
mesh::TetMesh atRest(mesh::TetMesh m) {
  m.positions = m.restPositions;
  m.boundaryFaces.clear();
  return m;
}

fem::SimulationSettings withCutRoom(fem::SimulationSettings settings, double room) {
  if (settings.cutRoom <= 0) settings.cutRoom = room;
  return settings;
}

}  // namespace

SoftBody::SoftBody(mesh::TetMesh tets, fem::SimulationSettings settings, SoftBodyOptions options)
    : settings_(withCutRoom(std::move(settings), options.cutRoom)), options_(options) {
  meanEdge_ = meanRestEdge(tets);
  cutter_ = std::make_unique<cutting::Cutter>(atRest(tets), options_.cut);
  sim_ = std::make_unique<fem::Simulation>(std::move(tets), settings_);
  parts_ = cutting::disjointParts(cutter_->topology());
}

SoftBody::~SoftBody() = default;
SoftBody::SoftBody(SoftBody&&) noexcept = default;
SoftBody& SoftBody::operator=(SoftBody&&) noexcept = default;

void SoftBody::setRenderSurface(mesh::TriMesh surface, fem::SurfaceEmbedding embedding) {
  sim_->setRenderSurface(std::move(surface), std::move(embedding));
}

std::vector<FragmentReport> SoftBody::fragments() const {
  std::vector<FragmentReport> all = removedFragments_;
  all.insert(all.end(), keptFragments_.begin(), keptFragments_.end());
  return all;
}

double SoftBody::time() const { return timeOffset_ + sim_->time(); }

void SoftBody::cutEvent(const std::vector<cutting::Triangle>& swept) {
  const std::size_t nodesBefore = sim_->mesh().nodeCount(), tetsBefore = sim_->mesh().tetCount();
  auto start = std::chrono::steady_clock::now();
  const cutting::CutResult event = cutter_->cut(swept);
  cutMs_ += msSince(start);
  ++events_;
  if (event.addedTets.empty() && event.newNodes.empty()) return;
  start = std::chrono::steady_clock::now();
  sim_->applyTopologyChange(toTopologyChange(event, cutter_->topology(), nodesBefore, tetsBefore));
  updateMs_ += msSince(start);
  splitTets_ += event.splitTets;
  partsChanged_ = true;
  if (options_.checkEachEvent) {
    const cutting::SelfCheckReport check = cutter_->topology().selfCheck();
    if (!check.ok()) throw std::runtime_error("cut event " + std::to_string(events_) + " failed the topology self-check: " + check.summary());
    ++checksPassed_;
  }
}

void SoftBody::cutBlade(const std::vector<BladeSegment>& blade) {
  const auto start = std::chrono::steady_clock::now();
  // The blade's points are mapped through the tets near it only: the map's region is the box of
  // the blade's positions this step, grown by two edge lengths.
  Box region{blade.front().a, blade.front().a};
  for (const BladeSegment& s : blade)
    for (const Double3& p : {s.a, s.b}) {
      region.lo = {std::min(region.lo.x, p.x), std::min(region.lo.y, p.y), std::min(region.lo.z, p.z)};
      region.hi = {std::max(region.hi.x, p.x), std::max(region.hi.y, p.y), std::max(region.hi.z, p.z)};
    }
  const double grow = 2 * meanEdge_;
  region.lo = {region.lo.x - grow, region.lo.y - grow, region.lo.z - grow};
  region.hi = {region.hi.x + grow, region.hi.y + grow, region.hi.z + grow};
  const MaterialMap map(sim_->mesh(), sim_->positions(), region, meanEdge_);
  // The blade's end points are mapped (SoftBodyOptions::bladeSegments > 1 maps points between
  // them too, the same count for the whole stroke), so consecutive polylines bound a strip.
  const std::size_t samples = strokePolyline_.empty() ? std::size_t(std::max(options_.bladeSegments, 1)) + 1 : strokePolyline_.size();
  double mappingMs = msSince(start);
  for (const BladeSegment& s : blade) {
    const auto mapStart = std::chrono::steady_clock::now();
    std::vector<Double3> polyline(samples);
    for (std::size_t i = 0; i < samples; ++i) {
      const double t = samples > 1 ? double(i) / double(samples - 1) : 0.0;
      polyline[i] = map.toMaterial({s.a.x + t * (s.b.x - s.a.x), s.a.y + t * (s.b.y - s.a.y), s.a.z + t * (s.b.z - s.a.z)});
    }
    if (strokePolyline_.empty()) {  // the stroke starts: nothing swept yet
      strokePolyline_ = std::move(polyline);
      mappingMs += msSince(mapStart);
      continue;
    }
    std::vector<cutting::Triangle> swept;
    for (std::size_t i = 0; i + 1 < samples; ++i) {
      const auto quad = cutting::sweptTriangles({0, strokePolyline_[i], strokePolyline_[i + 1]}, {1, polyline[i], polyline[i + 1]});
      swept.insert(swept.end(), quad.begin(), quad.end());
    }
    strokePolyline_ = std::move(polyline);
    mappingMs += msSince(mapStart);
    if (swept.empty()) continue;  // the blade did not move
    stroke_.insert(stroke_.end(), swept.begin(), swept.end());
    std::vector<cutting::Triangle> event = swept;
    if (options_.resweepPreviousStep) event.insert(event.end(), previous_.begin(), previous_.end());
    previous_ = std::move(swept);
    cutEvent(event);
  }
  cutMs_ += mappingMs;
}

void SoftBody::finishStroke() {
  for (int pass = 0; pass < options_.finalStrokePasses && !stroke_.empty(); ++pass) {
    const std::size_t before = splitTets_;
    cutEvent(stroke_);
    if (splitTets_ == before) break;
  }
  strokePolyline_.clear();
  stroke_.clear();
  previous_.clear();
}

void SoftBody::updateParts() {
  if (!partsChanged_) return;
  partsChanged_ = false;
  parts_ = cutting::disjointParts(cutter_->topology());
  const std::size_t total = cutter_->topology().liveTetCount();
  const FragmentPolicy& policy = options_.fragments;
  const std::size_t limit = std::max(policy.maxTets, std::size_t(policy.maxFraction * double(total)));
  std::vector<std::uint32_t> remove;
  std::vector<std::vector<std::uint32_t>> kept;
  keptFragments_.clear();  // found afresh: a kept fragment stays one report
  for (std::size_t p = 0; p < parts_.size(); ++p) {
    const bool fragment = p > 0 && parts_[p].size() <= limit;
    if (!fragment) {
      kept.push_back(std::move(parts_[p]));
      continue;
    }
    const bool removed = policy.action == FragmentPolicy::Action::Remove;
    (removed ? removedFragments_ : keptFragments_).push_back({time(), parts_[p].size(), removed});
    if (removed) remove.insert(remove.end(), parts_[p].begin(), parts_[p].end());
    else kept.push_back(std::move(parts_[p]));
  }
  parts_ = std::move(kept);
  if (!remove.empty()) resect(remove);
}

void SoftBody::resect(const std::vector<std::uint32_t>& slots) {
  if (slots.empty()) return;
  const auto start = std::chrono::steady_clock::now();
  cutting::CutTopology& topology = cutter_->topology();
  std::vector<std::uint32_t> sorted = slots;
  std::sort(sorted.begin(), sorted.end());
  if (std::adjacent_find(sorted.begin(), sorted.end()) != sorted.end()) throw std::invalid_argument("resect: a tet is listed twice");
  for (std::uint32_t s : sorted)
    if (s >= topology.slotCount() || !topology.alive(s)) throw std::invalid_argument("resect: tet " + std::to_string(s) + " is not in the body");
  if (sorted.size() >= topology.liveTetCount()) throw std::invalid_argument("resect: cannot remove every tet of the body");
  for (std::uint32_t s : sorted) topology.removeTet(s);
  topology.compact();

  // The FEM again over the remaining tets, with the state carried over. Node indices do not
  // change, so positions, velocities, pins and a lift's node list stay valid.
  mesh::TetMesh rest = topology.mesh();  // positions are rest positions (atRest)
  rest.boundaryFaces.clear();
  mesh::TetMesh body = rest;
  body.positions = sim_->positions();
  const std::vector<Double3> velocities = sim_->velocities();
  std::vector<std::uint8_t> used(body.nodeCount(), 0);
  for (const auto& t : body.tets)
    for (std::uint32_t v : t) used[v] = 1;
  fem::SimulationSettings settings = settings_;
  settings.fixedNodes.clear();
  for (std::uint32_t v = 0; v < body.nodeCount(); ++v)
    if (sim_->fixedMask()[v] || !used[v]) settings.fixedNodes.push_back(v);
  const double time = this->time();
  auto sim = std::make_unique<fem::Simulation>(std::move(body), settings);
  sim->setVelocities(velocities);
  sim_ = std::move(sim);
  timeOffset_ = time;
  cutter_ = std::make_unique<cutting::Cutter>(std::move(rest), options_.cut);
  parts_ = cutting::disjointParts(cutter_->topology());
  partsChanged_ = false;
  updateMs_ += msSince(start);
}

void SoftBody::step(const StepInput& input) {
  const auto cutStart = std::chrono::steady_clock::now();
  lastCutMs_ = 0;
  const bool cutting = !input.blade.empty() || !strokePolyline_.empty();
  if (!input.blade.empty()) cutBlade(input.blade);
  if (input.endStroke || (input.blade.empty() && !strokePolyline_.empty())) finishStroke();
  updateParts();
  if (cutting) lastCutMs_ = msSince(cutStart);

  // The tools' poses: the caller's, else their paths at the end of this step (the FEM's own
  // clock restarts when a resection rebuilds it, this body's does not).
  const double h = sim_->settings().timeStep;
  std::vector<fem::ToolPose> poses = input.tools;
  if (poses.empty())
    for (const fem::Tool& tool : settings_.tools) poses.push_back(tool.poseAt(time() + h));
  sim_->setToolPoses(std::move(poses));
  sim_->step();
  lastFemMs_ = sim_->lastStats().totalMs;
  for (const auto& x : sim_->positions())
    if (!std::isfinite(x.x) || !std::isfinite(x.y) || !std::isfinite(x.z))
      throw std::runtime_error("the simulation diverged at t = " + std::to_string(time()) + " (NaN)");
}

}  // namespace blobvk::surgery
