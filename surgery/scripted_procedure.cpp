#include "blobvk/surgery/scripted_procedure.h"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace blobvk::surgery {
namespace {

cutting::BladePath bladePath(const std::vector<BladeKeyframe>& keys) {
  cutting::BladePath path;
  for (std::size_t i = 0; i < keys.size(); ++i) {
    if (i > 0 && !(keys[i].time > keys[i - 1].time))
      throw std::invalid_argument("blade keyframe " + std::to_string(i) + ": times must increase strictly (they are simulation times)");
    path.keyframes.push_back({keys[i].time, keys[i].a, keys[i].b});
  }
  return path;
}

}  // namespace

ScriptedProcedure::ScriptedProcedure(mesh::TetMesh tets, const SimulationConfig& config, const std::vector<BladeKeyframe>& blade,
                                     SoftBodyOptions options)
    : body_(std::move(tets), config.settings, options), blade_(bladePath(blade)) {
  if (config.lift) lift_.emplace(*config.lift);
  strokeFinished_ = blade_.keyframes.size() < 2;
}

void ScriptedProcedure::step() {
  const double t0 = body_.time(), h = body_.simulation().settings().timeStep, t1 = t0 + h;
  StepInput input;
  if (!strokeFinished_) {
    // The blade where it is at the step's start (or its first keyframe), at every keyframe inside
    // the step and at the step's end: one cut event per interval, as cutting::runBladePath makes
    // them for a blade faster than the time step.
    const auto& keys = blade_.keyframes;
    const double from = std::max(t0, keys.front().time), to = std::min(t1, keys.back().time);
    if (to >= from && t1 > keys.front().time) {
      auto add = [&](double t) {
        const cutting::BladeKeyframe k = cutting::bladeAt(blade_, t);
        input.blade.push_back({k.edge0, k.edge1});
      };
      // Keyframes closer than a millionth of a step to the ends are the ends (the clock adds h
      // in floating point): a sliver interval would be an event of its own and become the
      // "previous interval" the next event sweeps again.
      const double slack = 1e-6 * h;
      if (!body_.strokeInProgress()) add(from);
      for (const auto& key : keys)
        if (key.time > from + slack && key.time < to - slack) add(key.time);
      add(to);
    }
    if (t1 >= keys.back().time) {
      input.endStroke = true;
      strokeFinished_ = true;
    }
  }
  body_.step(input);
  // The lift waits for the cut to be complete, so no later event splits the part it carries; it
  // places the part where its path has it at the end of the step.
  if (lift_ && strokeFinished_ && !lift_->started()) lift_->tryStart(t1, body_.parts(), body_.simulation());
  if (lift_) lift_->drive(t1, body_.simulation());
}

}  // namespace blobvk::surgery
