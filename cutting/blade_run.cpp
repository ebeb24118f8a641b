#include "blobvk/cutting/blade_run.h"

#include "blobvk/cutting/parts.h"

#include <stdexcept>
#include <unordered_map>

namespace blobvk::cutting {

BladeRunResult runBladePath(mesh::TetMesh mesh, const BladePath& path, const BladeRunOptions& options) {
  for (std::size_t i = 1; i < path.keyframes.size(); ++i)
    if (!(path.keyframes[i].time > path.keyframes[i - 1].time))
      throw std::invalid_argument("runBladePath: keyframe times must increase strictly");
  BladeRunResult run;
  run.before = meshQuality(mesh);
  Cutter cutter(std::move(mesh), options.cut);
  std::vector<Triangle> stroke;
  for (std::size_t i = 1; i < path.keyframes.size(); ++i) {
    const auto step = sweptTriangles(path.keyframes[i - 1], path.keyframes[i]);
    stroke.insert(stroke.end(), step.begin(), step.end());
    std::vector<Triangle> swept = sweptTriangles(path.keyframes[i - 1], path.keyframes[i]);
    if (options.resweepPreviousStep && i >= 2) {
      const auto previous = sweptTriangles(path.keyframes[i - 2], path.keyframes[i - 1]);
      swept.insert(swept.end(), previous.begin(), previous.end());
    }
    run.events.push_back(cutter.cut(swept));
    if (options.checkTopologyEachEvent) run.checks.push_back(cutter.topology().selfCheck());
  }
  for (int pass = 0; pass < options.finalStrokePasses && path.keyframes.size() > 2; ++pass) {
    run.events.push_back(cutter.cut(stroke));
    if (options.checkTopologyEachEvent) run.checks.push_back(cutter.topology().selfCheck());
    if (run.events.back().splitTets == 0) break;
  }
  run.finalCheck = cutter.topology().selfCheck();
  // Parts as indices into the compacted mesh (live slots in order).
  std::unordered_map<std::uint32_t, std::uint32_t> compactIndex;
  for (std::uint32_t s = 0, k = 0; s < cutter.topology().slotCount(); ++s)
    if (cutter.topology().alive(s)) compactIndex[s] = k++;
  for (auto& part : disjointParts(cutter.topology())) {
    for (auto& s : part) s = compactIndex.at(s);
    run.parts.push_back(std::move(part));
  }
  run.mesh = cutter.topology().toTetMesh();
  run.after = meshQuality(run.mesh);
  return run;
}

}  // namespace blobvk::cutting
