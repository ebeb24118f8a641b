// Touches a vector's reserved headroom once, so that the pages behind it are mapped before a
// cutting session starts: a cut event appends children, nodes and incidence entries into that
// headroom, and every first touch of a fresh page is a page fault (~80 per event at 105k tets,
// several microseconds each on a loaded machine) that instruction counts do not show.
#pragma once

#include <vector>

namespace blobvk::cutting {

// Value-initialises the elements up to the capacity and drops them again: size and capacity are
// unchanged, the memory is now resident (T is a trivially copyable record here).
template <typename T>
void prefaultCapacity(std::vector<T>& v) {
  const std::size_t size = v.size();
  v.resize(v.capacity());
  v.resize(size);
}

}  // namespace blobvk::cutting
