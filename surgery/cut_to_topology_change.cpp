#include "blobvk/surgery/cut_to_topology_change.h"

#include "blobvk/cutting/radix_sort.h"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace blobvk::surgery {

fem::TopologyChange toTopologyChange(const cutting::CutResult& event, const cutting::CutTopology& after,
                                     std::size_t nodesBefore, std::size_t tetsBefore) {
  auto fail = [](const std::string& why) { throw std::logic_error("cut event -> topology change: " + why); };
  fem::TopologyChange change;
  if (after.mesh().nodeCount() != nodesBefore + event.newNodes.size())
    fail("the cutter has " + std::to_string(after.mesh().nodeCount()) + " nodes, expected " +
         std::to_string(nodesBefore) + " + " + std::to_string(event.newNodes.size()) + " new");
  change.newNodes.reserve(event.newNodes.size());
  for (std::size_t k = 0; k < event.newNodes.size(); ++k) {
    const cutting::NewNode& n = event.newNodes[k];
    // The FEM appends in list order, so the list must be in index order.
    if (n.index != nodesBefore + k) fail("new node " + std::to_string(n.index) + " is out of order");
    fem::NodeOrigin o;
    for (std::size_t i = 0; i < 4; ++i) {
      o.sources[i] = n.sources[i] == cutting::kNone ? fem::kNoSource : n.sources[i];
      o.weights[i] = n.sources[i] == cutting::kNone ? 0.0 : n.weights[i];
    }
    change.newNodes.push_back(o);
  }

  change.movedNodes.reserve(event.movedNodes.size());
  for (const cutting::MovedNode& m : event.movedNodes) {
    fem::NodeMove move;
    move.node = m.index;
    move.origin.sources = m.sources;
    move.origin.weights = m.weights;
    change.movedNodes.push_back(move);
  }

  // A slot may be written twice in one event (split, then re-pointed at a duplicated node):
  // its final content is what counts.
  std::vector<std::uint32_t> slots = event.addedTets, scratch;
  // Radix-sorted: std::sort was most of this conversion (~2,000 slots an event, ~150
  // instructions each).
  const std::uint32_t largest = slots.empty() ? 0u : *std::max_element(slots.begin(), slots.end());
  cutting::radixSort(slots, scratch, largest, [](std::uint32_t slot) { return slot; });
  slots.erase(std::unique(slots.begin(), slots.end()), slots.end());
  for (std::uint32_t removed : event.removedTets)
    if (!std::binary_search(slots.begin(), slots.end(), removed)) fail("tet slot " + std::to_string(removed) + " was removed and not refilled");
  if (after.slotCount() != after.liveTetCount()) fail("the cutter's mesh has holes (dead tet slots)");
  const auto& regions = after.mesh().regions;
  std::size_t end = tetsBefore;
  for (std::uint32_t slot : slots) {
    if (slot >= after.slotCount()) fail("tet slot " + std::to_string(slot) + " is past the cutter's mesh");
    if (slot > end) fail("appended tet slot " + std::to_string(slot) + " leaves a gap after " + std::to_string(end));
    if (slot == end) ++end;
    change.tetSlots.push_back(slot);
    change.tetNodes.push_back(after.tet(slot));
    change.tetRegions.push_back(regions.empty() ? 0u : regions[slot]);
  }
  if (end != after.slotCount()) fail("the cutter has " + std::to_string(after.slotCount()) + " tet slots, the change reaches " + std::to_string(end));
  return change;
}

}  // namespace blobvk::surgery
