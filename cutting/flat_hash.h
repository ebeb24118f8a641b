// Open-addressing hash map for the cutting topology's hot lookups (edge and face records, and
// the per-event scratch sets of the cutter). Linear probing over one flat array with a power-of-
// two capacity, load factor <= 1/2, and backward-shift deletion (no tombstones, so lookups stay
// short however many inserts and erases a long cutting session makes). std::unordered_map spent
// most of a cut event chasing node pointers; here a lookup is one or two cache lines.
//
// Keys are trivially copyable; one key value (`empty`, given at construction) marks free slots
// and must never be inserted. Pointers returned by find/insert are invalidated by any insert.
#pragma once

#include <algorithm>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <utility>
#include <vector>

namespace blobvk::cutting {

// Finaliser of splitmix64: every input bit affects every output bit.
inline std::uint64_t mix64(std::uint64_t x) {
  x ^= x >> 30;
  x *= 0xBF58476D1CE4E5B9ull;
  x ^= x >> 27;
  x *= 0x94D049BB133111EBull;
  x ^= x >> 31;
  return x;
}

template <typename Key, typename Value, typename Hash>
class FlatHashMap {
 public:
  struct Entry {
    Key key;
    Value value;
  };

  explicit FlatHashMap(Key empty, std::size_t expected = 0) : empty_(empty) { reserve(expected); }

  std::size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }

  // Capacity for `count` entries without rehashing.
  void reserve(std::size_t count) {
    std::size_t capacity = 16;
    while (capacity < 2 * count) capacity *= 2;
    if (capacity > slots_.size()) rehash(capacity);
  }

  // Removes every entry; O(capacity). Keeps the memory.
  void clear() {
    if (size_ == 0) return;
    for (Entry& e : slots_) e.key = empty_;
    size_ = 0;
  }

  // Starts loading the home slot of key: a caller about to touch several keys issues all the
  // prefetches first, so their cache misses overlap instead of queueing.
  void prefetch(const Key& key) const {
    if (!slots_.empty()) __builtin_prefetch(&slots_[home(key)], 1);
  }

  Value* find(const Key& key) {
    if (slots_.empty()) return nullptr;
    for (std::size_t i = home(key);; i = (i + 1) & mask_) {
      Entry& e = slots_[i];
      if (e.key == key) return &e.value;
      if (e.key == empty_) return nullptr;
    }
  }
  const Value* find(const Key& key) const { return const_cast<FlatHashMap*>(this)->find(key); }
  bool contains(const Key& key) const { return find(key) != nullptr; }

  // The value of `key`, inserted as `init` if absent; .second is true when inserted.
  std::pair<Value*, bool> insert(const Key& key, const Value& init = Value{}) {
    if (key == empty_) throw std::logic_error("FlatHashMap: the empty key cannot be inserted");
    if (2 * (size_ + 1) > slots_.size()) rehash(std::max<std::size_t>(16, 2 * slots_.size()));
    for (std::size_t i = home(key);; i = (i + 1) & mask_) {
      Entry& e = slots_[i];
      if (e.key == key) return {&e.value, false};
      if (e.key == empty_) {
        e.key = key;
        e.value = init;
        ++size_;
        return {&e.value, true};
      }
    }
  }
  Value& operator[](const Key& key) { return *insert(key).first; }

  bool erase(const Key& key) {
    if (slots_.empty()) return false;
    std::size_t i = home(key);
    for (;; i = (i + 1) & mask_) {
      if (slots_[i].key == key) break;
      if (slots_[i].key == empty_) return false;
    }
    // Backward shift: move later entries of the probe run into the hole when their home slot
    // does not lie cyclically in (hole, position].
    std::size_t hole = i;
    for (std::size_t j = (i + 1) & mask_;; j = (j + 1) & mask_) {
      if (slots_[j].key == empty_) break;
      const std::size_t h = home(slots_[j].key);
      const bool stays = hole <= j ? (hole < h && h <= j) : (hole < h || h <= j);
      if (stays) continue;
      slots_[hole] = slots_[j];
      hole = j;
    }
    slots_[hole].key = empty_;
    --size_;
    return true;
  }

  template <typename F>
  void forEach(F&& f) const {
    for (const Entry& e : slots_)
      if (!(e.key == empty_)) f(e.key, e.value);
  }

 private:
  // Fibonacci hashing: the top bits of hash * 2^64 / golden ratio. Every bit of the hash moves
  // the top bits, so plain integer keys (edge keys, cell keys) need no mixing of their own.
  std::size_t home(const Key& key) const {
    return std::size_t((std::uint64_t(Hash{}(key)) * 0x9E3779B97F4A7C15ull) >> shift_);
  }

  void rehash(std::size_t capacity) {
    std::vector<Entry> old(capacity, Entry{empty_, Value{}});
    old.swap(slots_);
    mask_ = capacity - 1;
    shift_ = 64 - std::countr_zero(std::uint64_t(capacity));
    size_ = 0;
    for (const Entry& e : old)
      if (!(e.key == empty_)) insert(e.key, e.value);
  }

  Key empty_;
  std::vector<Entry> slots_;
  std::size_t mask_ = 0;
  int shift_ = 63;
  std::size_t size_ = 0;
};

// Integer keys hash to themselves (the table's Fibonacci step spreads them).
struct U64Hash {
  std::uint64_t operator()(std::uint64_t k) const { return k; }
};
struct U32Hash {
  std::uint64_t operator()(std::uint32_t k) const { return k; }
};

// A set of keys: the same probing and hashing over a table of keys alone (a map with an empty
// value would pad each slot to twice the key's size, and the cutter clears and probes these
// tables every event).
template <typename Key, typename Hash>
class FlatHashSet {
 public:
  explicit FlatHashSet(Key empty, std::size_t expected = 0) : empty_(empty) { reserve(expected); }

  void reserve(std::size_t count) {
    std::size_t capacity = 16;
    while (capacity < 2 * count) capacity *= 2;
    if (capacity > slots_.size()) rehash(capacity);
  }
  // True when the key was not there yet.
  bool insert(const Key& key) {
    if (key == empty_) throw std::logic_error("FlatHashSet: the empty key cannot be inserted");
    if (2 * (size_ + 1) > slots_.size()) rehash(std::max<std::size_t>(16, 2 * slots_.size()));
    for (std::size_t i = home(key);; i = (i + 1) & mask_) {
      if (slots_[i] == key) return false;
      if (slots_[i] == empty_) {
        slots_[i] = key;
        ++size_;
        return true;
      }
    }
  }
  bool contains(const Key& key) const {
    if (slots_.empty()) return false;
    for (std::size_t i = home(key);; i = (i + 1) & mask_) {
      if (slots_[i] == key) return true;
      if (slots_[i] == empty_) return false;
    }
  }
  std::size_t size() const { return size_; }
  // O(capacity); keeps the memory.
  void clear() {
    if (size_ == 0) return;
    std::fill(slots_.begin(), slots_.end(), empty_);
    size_ = 0;
  }
  template <typename F>
  void forEach(F&& f) const {
    for (const Key& k : slots_)
      if (!(k == empty_)) f(k);
  }

 private:
  std::size_t home(const Key& key) const {
    return std::size_t((std::uint64_t(Hash{}(key)) * 0x9E3779B97F4A7C15ull) >> shift_);
  }
  void rehash(std::size_t capacity) {
    std::vector<Key> old(capacity, empty_);
    old.swap(slots_);
    mask_ = capacity - 1;
    shift_ = 64 - std::countr_zero(std::uint64_t(capacity));
    size_ = 0;
    for (const Key& k : old)
      if (!(k == empty_)) insert(k);
  }

  Key empty_;
  std::vector<Key> slots_;
  std::size_t mask_ = 0;
  int shift_ = 63;
  std::size_t size_ = 0;
};

}  // namespace blobvk::cutting
