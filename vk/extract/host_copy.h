// Copying a batch's outputs from read-back memory into the mesh's vectors with every core. A
// mesh at 2048^3 is a gigabyte, and one thread filling fresh pages (a page fault per 4 KiB, then
// the copy) took longer than the device's whole job on a discrete GPU.
#pragma once

#include <algorithm>
#include <exception>
#include <cstddef>
#include <type_traits>
#include <vector>

namespace blobvk::vk {

// Below this many bytes a copy stays on the calling thread (threads cost more than they save).
inline constexpr std::size_t kParallelCopyBytes = std::size_t(8) << 20;

// Writes one byte per page of [p, p + bytes) from several threads, so the kernel maps fresh
// memory in parallel instead of in the single-threaded copy or fill that follows.
void prefaultParallel(void* p, std::size_t bytes);
// memcpy in chunks over the worker threads.
void copyParallel(void* dst, const void* src, std::size_t bytes);

// Room in v for n more elements, their pages mapped over the cores. Where v must move, it moves
// into room for max(reserveFor, twice its size) elements, what it holds copied over the cores
// (only the part it will fill is mapped now). Allocates on the calling thread, so that a vector
// freed there is reused there (each thread has its own malloc arena).
template <class T, class A>
void roomFor(std::vector<T, A>& v, std::size_t n, std::size_t reserveFor = 0) {
  static_assert(std::is_trivially_copyable_v<T>);
  const std::size_t old = v.size(), bytes = n * sizeof(T);
  if (bytes < kParallelCopyBytes) {
    if (v.capacity() < old + n) v.reserve(std::max({old + n, 2 * old, reserveFor}));
    return;
  }
  if (v.capacity() < old + n) {
    std::vector<T, A> grown;
    const std::size_t needed = std::max(old + n, 2 * old);
    try {
      grown.reserve(std::max(needed, reserveFor));
    } catch (const std::exception&) {  // bad_alloc, length_error: the room asked for ahead is a wish
      if (reserveFor <= needed) throw;
      grown.reserve(needed);
    }
    prefaultParallel(grown.data(), (old + n) * sizeof(T));
    grown.resize(old);
    if (old) copyParallel(grown.data(), v.data(), old * sizeof(T));
    v.swap(grown);
  } else {
    prefaultParallel(v.data() + old, bytes);
  }
}

// roomFor's reserveFor for a vector about to hold `size` elements that later appends will take to
// about `ratio` times that (0, nothing ahead, for a ratio of 1 or less).
inline std::size_t roomAhead(std::size_t size, double ratio) {
  return ratio > 1.0 ? std::size_t(double(size) * ratio) : 0;
}

// v grown by n elements in the room roomFor made; returns the first new one. A mesh's arrays
// (mesh::MeshArray) leave them unwritten, for the copy that follows; a std::vector
// value-initialises them, a fill that is one thread's: callers grow several vectors at once, or
// while the device works (vk/extract/sparse_batches.cpp).
template <class T, class A>
T* appendElements(std::vector<T, A>& v, std::size_t n) {
  v.resize(v.size() + n);
  return v.data() + v.size() - n;
}

// roomFor, then appendElements.
template <class T, class A>
T* growParallel(std::vector<T, A>& v, std::size_t n, std::size_t reserveFor = 0) {
  roomFor(v, n, reserveFor);
  return appendElements(v, n);
}

// v.insert(v.end(), src, src + n), with the page faults and the copy spread over the cores.
template <class T, class A>
void appendParallel(std::vector<T, A>& v, const T* src, std::size_t n) {
  static_assert(std::is_trivially_copyable_v<T>);
  if (n * sizeof(T) < kParallelCopyBytes) {
    v.insert(v.end(), src, src + n);
    return;
  }
  copyParallel(growParallel(v, n), src, n * sizeof(T));
}

}  // namespace blobvk::vk
