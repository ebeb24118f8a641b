// Reserved room that is already mapped: a vector's reserve() only takes address space, and the
// first write to each 4 KiB page then costs a page fault (about a microsecond with zeroing).
// Appends made by a topology change would pay that in the middle of a cut event; touching the
// room once at construction moves the cost there.
#pragma once

#include <cstddef>
#include <vector>

namespace blobvk::fem {

// Capacity for `count` elements plus the growth cuts bring (SimulationSettings::cutRoom): a cut
// event at ~100k tets appends ~2 % more tets and nodes, so room = 0.5 takes ~25 events before a
// vector has to reallocate (a copy of all of it: tens of ms at 100k tets, which no haptic frame
// could absorb).
inline std::size_t withCutRoom(std::size_t count, double room) {
  return room > 0 ? count + std::size_t(double(count) * room) + 64 : count;
}

template <class T>
void reserveTouched(std::vector<T>& v, std::size_t capacity) {
  if (capacity <= v.size()) return;
  v.reserve(capacity);
  const std::size_t size = v.size();
  v.resize(capacity);  // value-initialises (writes) the room; shrinking back keeps the capacity
  v.resize(size);
}

}  // namespace blobvk::fem
