// Host plans that a repeated job would compute again every run (an engine re-meshing the same
// model, `blobvk bench`'s repeats): the tiles' plan and which tiles get kernels of their own take
// tens of milliseconds for a program of thousands of instructions (tower_L6P8I4: 97 ms of a
// 130 ms job on an H100). Remembered process-wide, thread-safe, under a 64-bit FNV-1a key of
// everything the plan depends on (the program's fingerprint included: the trust the kernel
// cache already puts in programFingerprint).
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <mutex>
#include <unordered_map>
#include <utility>
#include <vector>

namespace blobvk::vk {

// FNV-1a, 64 bits, over plain data without padding holes, eight bytes a step (each step folds
// the high half down, so that a word's high bits reach the low ones): these memos' keys and the
// program and evaluator fingerprints (programFingerprint, evaluatorFingerprint). A job hashes its
// program tens of times; byte by byte that was 30 us a time for the tower.
struct MemoKey {
  std::uint64_t h = 14695981039346656037ull;
  MemoKey& bytes(const void* p, std::size_t n) {
    const auto* b = static_cast<const unsigned char*>(p);
    std::size_t i = 0;
    for (; i + 8 <= n; i += 8) {
      std::uint64_t w;
      std::memcpy(&w, b + i, 8);
      h = (h ^ w) * 1099511628211ull;
      h ^= h >> 32;
    }
    for (; i < n; ++i) h = (h ^ b[i]) * 1099511628211ull;
    return *this;
  }
  template <class T>
  MemoKey& add(const T& v) {
    return bytes(&v, sizeof v);
  }
  template <class T>
  MemoKey& array(const std::vector<T>& v) {  // its length, then its elements
    add(std::uint64_t(v.size()));
    return bytes(v.data(), v.size() * sizeof(T));
  }
};

// At most `Capacity` plans; a full memo starts again empty (jobs repeat the last few models).
template <class Value, std::size_t Capacity = 64>
class HostMemo {
 public:
  template <class Compute>
  Value get(const MemoKey& key, Compute&& compute) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (auto it = values_.find(key.h); it != values_.end()) return it->second;
    }
    Value v = compute();  // outside the lock: plans for different keys may run at once
    std::lock_guard<std::mutex> lock(mutex_);
    if (values_.size() >= Capacity) values_.clear();
    values_.emplace(key.h, v);
    return v;
  }

 private:
  std::mutex mutex_;
  std::unordered_map<std::uint64_t, Value> values_;
};

}  // namespace blobvk::vk
