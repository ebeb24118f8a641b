#include "blobvk/fem/node_incidence.h"

#include "blobvk/fem/reserve_touched.h"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace blobvk::fem {
namespace {

constexpr std::uint32_t kSpare = 4;  // free entries per row after a build: a few cuts need no move

std::uint32_t pack(std::uint32_t tet, int corner) {
  if (tet >= (1u << 30)) throw std::length_error("node incidence: more than 2^30 tets");
  return (tet << 2) | std::uint32_t(corner);
}

}  // namespace

void NodeIncidence::build(std::size_t n, const std::vector<std::array<std::uint32_t, 4>>& tets, double cutRoom) {
  count_.assign(n, 0);
  for (const auto& t : tets)
    for (auto v : t) ++count_[v];
  start_.resize(n);
  capacity_.resize(n);
  std::size_t offset = 0;
  for (std::size_t r = 0; r < n; ++r) {
    start_[r] = std::uint32_t(offset);
    capacity_[r] = count_[r] + kSpare;
    offset += capacity_[r];
  }
  entries_.assign(offset, 0);
  reserveTouched(entries_, 2 * offset);  // room for new rows and rows that outgrow their spare entries
  for (auto* v : {&start_, &count_, &capacity_}) reserveTouched(*v, withCutRoom(n, cutRoom));
  std::vector<std::uint32_t> fill(n, 0);
  // Tets in increasing order: every row comes out sorted without a sort.
  for (std::size_t e = 0; e < tets.size(); ++e)
    for (int i = 0; i < 4; ++i) {
      const std::uint32_t v = tets[e][std::size_t(i)];
      entries_[start_[v] + fill[v]++] = pack(std::uint32_t(e), i);
    }
}

void NodeIncidence::addNodes(std::size_t count) {
  const std::size_t first = entries_.size();
  entries_.resize(first + count * kSpare, 0);
  for (std::size_t k = 0; k < count; ++k) {
    start_.push_back(std::uint32_t(first + k * kSpare));
    count_.push_back(0);
    capacity_.push_back(kSpare);
  }
}

void NodeIncidence::grow(std::size_t r) {
  const std::uint32_t newCapacity = 2 * capacity_[r] + kSpare;
  const std::size_t newStart = entries_.size();
  if (newStart + newCapacity > (1ull << 32) - 1) throw std::length_error("node incidence: storage over 2^32 entries");
  entries_.resize(newStart + newCapacity, 0);
  const auto row = entries_.begin() + start_[r];
  std::copy(row, row + count_[r], entries_.begin() + std::ptrdiff_t(newStart));
  start_[r] = std::uint32_t(newStart);
  capacity_[r] = newCapacity;
}

void NodeIncidence::insertEntry(std::uint32_t r, std::uint32_t entry) {
  if (r >= start_.size()) throw std::out_of_range("node incidence: node " + std::to_string(r) + " out of range");
  if (count_[r] == capacity_[r]) grow(r);
  std::uint32_t* b = entries_.data() + start_[r];
  std::uint32_t* e = b + count_[r];
  if (b == e || e[-1] < entry) {
    *e = entry;  // the common case: an appended tet sorts after every entry of the row
  } else {
    std::uint32_t* at = std::lower_bound(b, e, entry);
    std::copy_backward(at, e, e + 1);
    *at = entry;
  }
  ++count_[r];
}

void NodeIncidence::addTet(std::uint32_t tet, const std::array<std::uint32_t, 4>& nodes) {
  for (int i = 0; i < 4; ++i) insertEntry(nodes[std::size_t(i)], pack(tet, i));
}

void NodeIncidence::removeEntry(std::uint32_t r, std::uint32_t entry) {
  std::uint32_t* b = entries_.data() + start_[r];
  std::uint32_t* e = b + count_[r];
  std::uint32_t* at = std::lower_bound(b, e, entry);
  if (at == e || *at != entry)
    throw std::logic_error("node incidence: tet " + std::to_string(tetOf(entry)) + " is not listed at node " + std::to_string(r));
  std::copy(at + 1, e, at);
  --count_[r];
}

void NodeIncidence::removeTet(std::uint32_t tet, const std::array<std::uint32_t, 4>& nodes) {
  for (int i = 0; i < 4; ++i) removeEntry(nodes[std::size_t(i)], pack(tet, i));
}


void NodeIncidence::replaceTet(std::uint32_t tet, const std::array<std::uint32_t, 4>& before,
                               const std::array<std::uint32_t, 4>& after) {
  std::array<std::uint32_t, 4> gone = before, come = after;  // kNone where a node stays
  constexpr std::uint32_t kNone = 0xffffffffu;
  for (std::size_t i = 0; i < 4; ++i)
    for (std::size_t j = 0; j < 4; ++j) {
      if (before[i] != after[j]) continue;
      const std::uint32_t r = before[i];
      std::uint32_t* b = entries_.data() + start_[r];
      std::uint32_t* at = std::lower_bound(b, b + count_[r], pack(tet, 0));
      if (at == b + count_[r] || tetOf(*at) != tet)
        throw std::logic_error("node incidence: tet " + std::to_string(tet) + " is not listed at node " + std::to_string(r));
      *at = pack(tet, int(j));  // same tet, same place in the sorted row
      gone[i] = come[j] = kNone;
    }
  for (std::size_t i = 0; i < 4; ++i) {
    if (gone[i] != kNone) removeEntry(gone[i], pack(tet, int(i)));
    if (come[i] != kNone) insertEntry(come[i], pack(tet, int(i)));
  }
}

}  // namespace blobvk::fem
