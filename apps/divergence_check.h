// The stop for a soft-body run that has blown up (too large a time step for a soft material):
// without it, positions past float range reach the frames as infinities and the run exits 0.
#pragma once

#include "blobvk/fem/simulation.h"

#include <string>

namespace blobvk::app {

class DivergenceCheck {
 public:
  // The body at rest: its centre and size, which later positions are measured against; `scene`
  // names the file whose simulation section the error points at.
  DivergenceCheck(const fem::Simulation& sim, std::string scene);
  // Throws std::runtime_error naming `step` when a node is not finite or lies farther from the
  // rest centre than 1000 times the rest body's size (no contact, gravity or tool moves a body
  // that far); `advice` ends the line.
  void check(const fem::Simulation& sim, int step, const std::string& advice) const;

 private:
  std::string scene_;
  double cx_ = 0, cy_ = 0, cz_ = 0, size_ = 0, limit_ = 0;
};

}  // namespace blobvk::app
