#include "blobvk/cutting/incidence_lists.h"

#include "blobvk/cutting/prefault.h"

#include <algorithm>

namespace blobvk::cutting {

void IncidenceLists::layout(const std::vector<std::uint32_t>& capacities) {
  runs_.assign(capacities.size(), Run{});
  std::size_t offset = 0;
  for (std::size_t n = 0; n < capacities.size(); ++n) {
    runs_[n].offset = std::uint32_t(offset);
    runs_[n].capacity = capacities[n];
    offset += capacities[n];
  }
  // Room for runs that move (split nodes gain tets) and for new nodes, so that a cutting
  // session's first events do not reallocate the whole pool, resident from the start (page
  // faults). Half the pool again ran out within bench_cutting's 16 strokes of ~500 swept tets on
  // 105k tets (page faults and a reallocation in the events); the pool's own size again does not.
  pool_.reserve(2 * offset + 4096);
  runs_.reserve(capacities.size() + capacities.size() / 2 + 1024);
  pool_.assign(offset, 0);
  prefaultCapacity(pool_);
  prefaultCapacity(runs_);
  abandoned_ = entries_ = 0;
}

void IncidenceLists::grow(std::uint32_t node) {
  // Move the run to the end of the pool with room to grow (8 fits a voxel node's 6-24 tets in
  // one or two moves; split nodes gain a few).
  const std::uint32_t capacity = std::max<std::uint32_t>(8, 2 * runs_[node].capacity);
  if (abandoned_ + runs_[node].capacity > pool_.size() / 2 && pool_.size() > 4096) compact();
  Run& run = runs_[node];  // compact() rewrote offsets
  const std::size_t offset = pool_.size();
  pool_.resize(offset + capacity);
  std::copy_n(pool_.begin() + run.offset, run.size, pool_.begin() + std::ptrdiff_t(offset));
  abandoned_ += run.capacity;
  run.offset = std::uint32_t(offset);
  run.capacity = capacity;
}

bool IncidenceLists::remove(std::uint32_t node, std::uint32_t item) {
  Run& r = runs_[node];
  std::uint32_t* begin = pool_.data() + r.offset;
  std::uint32_t* end = begin + r.size;
  std::uint32_t* it = std::find(begin, end, item);
  if (it == end) return false;
  *it = *(end - 1);
  --r.size;
  --entries_;
  return true;
}

void IncidenceLists::compact() {
  std::vector<std::uint32_t> packed;
  std::size_t total = 0;
  for (const Run& r : runs_) total += r.capacity;
  packed.reserve(total + total / 2 + 64);
  for (Run& r : runs_) {
    const std::size_t offset = packed.size();
    packed.insert(packed.end(), pool_.begin() + r.offset, pool_.begin() + r.offset + r.size);
    packed.resize(offset + r.capacity);
    r.offset = std::uint32_t(offset);
  }
  pool_.swap(packed);
  abandoned_ = 0;
}

}  // namespace blobvk::cutting
