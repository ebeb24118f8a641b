// One cut event as a change to the running FEM: cutting::CutResult (what the Cutter did to its
// topology) -> fem::TopologyChange (what Simulation::applyTopologyChange takes).
#pragma once

#include "blobvk/cutting/cutter.h"
#include "blobvk/fem/simulation.h"

#include <cstddef>

namespace blobvk::surgery {

// `after` is the cutter's topology after the event; `nodesBefore` and `tetsBefore` are the
// simulation's counts before it (they must equal the cutter's before the event). New nodes keep
// their order, sources and weights; every slot the event wrote (rewritten or appended) is listed
// once, ascending, with its nodes and region as they are now. Throws std::logic_error when the
// event cannot be expressed (a slot removed and not refilled, new node indices out of order).
fem::TopologyChange toTopologyChange(const cutting::CutResult& event, const cutting::CutTopology& after,
                                     std::size_t nodesBefore, std::size_t tetsBefore);

}  // namespace blobvk::surgery
