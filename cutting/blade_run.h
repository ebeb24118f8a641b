// Runs a blade path against a tet mesh: the entry point for `blobvk cut`. One cut event per
// keyframe step; each event also re-sweeps the previous step so tets the blade stopped inside
// (partial cases C, D, E) are finished when the blade moves on; the whole stroke is swept once
// more at the end (closing seams, bends).
#pragma once

#include "blobvk/cutting/blade.h"
#include "blobvk/cutting/cutter.h"
#include "blobvk/cutting/quality.h"

#include <vector>

namespace blobvk::cutting {

struct BladeRunOptions {
  CutOptions cut;
  bool resweepPreviousStep = true;
  // After the last keyframe, sweep the whole stroke's surface again (up to this many times, until
  // nothing splits): finishes tets left partial where the path closes on itself or bends.
  int finalStrokePasses = 2;
  bool checkTopologyEachEvent = false;  // O(n) self-check after every event (tests, debugging)
};

struct BladeRunResult {
  std::vector<CutResult> events;
  std::vector<SelfCheckReport> checks;  // one per event when checkTopologyEachEvent
  QualityStats before, after;           // at rest
  std::vector<std::vector<std::uint32_t>> parts;  // tet indices into `mesh`, largest first
  mesh::TetMesh mesh;                   // compacted result with boundary faces
  SelfCheckReport finalCheck;
};

BladeRunResult runBladePath(mesh::TetMesh mesh, const BladePath& path, const BladeRunOptions& options = {});

}  // namespace blobvk::cutting
