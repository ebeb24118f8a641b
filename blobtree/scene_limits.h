// Sanity limits shared by the scene readers: anything beyond them is treated as a broken or
// hostile file rather than a model, so readers fail with a SceneError instead of exhausting the
// stack or memory.
#pragma once

#include <cstddef>

namespace blobvk::blobtree::limits {

inline constexpr std::size_t kMaxSceneBytes = std::size_t(256) << 20;  // a scene file's size
inline constexpr std::size_t kMaxDepth = 4096;       // nodes on the path from the root to a leaf
inline constexpr std::size_t kMaxNodes = 4'000'000;  // nodes after instance expansion
// Bytes of node ids after instance expansion (each copy keeps its id): a few long ids instanced
// many times would otherwise exhaust memory well inside kMaxNodes.
inline constexpr std::size_t kMaxIdBytes = std::size_t(64) << 20;
inline constexpr double kMaxAbsValue = 1e6;          // any coordinate, radius, factor, ...
// A primitive's smallest support radius: the compiler scales each skeleton into its unit frame by
// 1 / support, in 32-bit floats.
inline constexpr double kMinSupport = 1e-6;
// A Ricci blend's smallest power n: (f1^n + f2^n + ...)^(1/n) overflows a float wherever the sum
// passes FLT_MAX^n (1.09 at n = 0.001: two children at 1 make the field infinite and the
// vertices between them NaN); at n = 0.1 it would take a sum above 7,000.
inline constexpr double kMinRicciPower = 0.1;

}  // namespace blobvk::blobtree::limits
