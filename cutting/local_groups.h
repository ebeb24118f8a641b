// Connected groups of a small set of items joined pairwise: the crack opening's tets around one
// vertex, glued through shared non-crack faces.
#pragma once

#include <algorithm>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <numeric>
#include <vector>

namespace blobvk::cutting {

// Groups of the tets around one vertex, joined pairwise (glued faces); each group is named by
// its smallest member (a rule independent of how the links were made). Up to 64 members (a
// vertex's usual 20-40 tets) as adjacency bit masks, whose components a few mask operations per
// member find; more as a union-find linking the larger root under the smaller.
class LocalGroups {
 public:
  void reset(std::size_t n) {
    n_ = n;
    if (n <= 64) {
      adjacency_.assign(n, 0);
    } else {
      parent_.resize(n);
      std::iota(parent_.begin(), parent_.end(), 0u);
    }
  }
  void link(std::uint32_t a, std::uint32_t b) {
    if (n_ <= 64) {
      adjacency_[a] |= std::uint64_t(1) << b;
      adjacency_[b] |= std::uint64_t(1) << a;
      return;
    }
    a = find(a), b = find(b);
    if (a != b) parent_[std::max(a, b)] = std::min(a, b);
  }
  // rootOf[i] = the smallest member of i's group.
  void roots(std::vector<std::uint32_t>& rootOf) {
    rootOf.resize(n_);
    if (n_ > 64) {
      for (std::size_t i = 0; i < n_; ++i) rootOf[i] = find(std::uint32_t(i));
      return;
    }
    std::uint64_t unvisited = n_ == 64 ? ~std::uint64_t(0) : (std::uint64_t(1) << n_) - 1;
    while (unvisited != 0) {
      const auto root = std::uint32_t(std::countr_zero(unvisited));
      std::uint64_t group = 0, frontier = std::uint64_t(1) << root;
      while (frontier != 0) {
        const int i = std::countr_zero(frontier);
        group |= std::uint64_t(1) << i;
        frontier = (frontier | adjacency_[std::size_t(i)]) & ~group;
      }
      unvisited &= ~group;
      for (std::uint64_t m = group; m != 0; m &= m - 1) rootOf[std::size_t(std::countr_zero(m))] = root;
    }
  }

 private:
  std::uint32_t find(std::uint32_t x) {
    std::uint32_t* p = parent_.data();
    while (p[x] != x) x = p[x] = p[p[x]];
    return x;
  }
  std::size_t n_ = 0;
  std::vector<std::uint64_t> adjacency_;
  std::vector<std::uint32_t> parent_;
};

}  // namespace blobvk::cutting
