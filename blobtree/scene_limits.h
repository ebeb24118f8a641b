// Sanity limits shared by the scene readers: anything beyond them is treated as a broken or
// hostile file rather than a model, so readers fail with a SceneError instead of exhausting the
// stack or memory.
#pragma once

#include <cstddef>

namespace blobvk::blobtree::limits {

inline constexpr std::size_t kMaxDepth = 4096;       // nodes on the path from the root to a leaf
inline constexpr std::size_t kMaxNodes = 4'000'000;  // nodes after instance expansion
inline constexpr double kMaxAbsValue = 1e6;          // any coordinate, radius, factor, ...

}  // namespace blobvk::blobtree::limits
