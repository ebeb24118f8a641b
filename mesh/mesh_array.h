// The arrays of a TriMesh: std::vector with an allocator under which resize(n) and vector(n)
// leave new elements of plain-data types unwritten. A mesh's arrays are written in full once
// they have their size (a polygonizer's copy out of the GPU's read-back memory, the CPU's
// welding), and a zero fill first was a second pass over up to gigabytes on one thread: on a
// discrete GPU it took longer than the device's whole job (the tower at 2048^3 on an H100: 84 ms
// of 134). resize(n, value), assign(n, value) and insert still write what they are given.
#pragma once

#include <memory>
#include <new>
#include <type_traits>
#include <utility>
#include <vector>

namespace blobvk::mesh {

template <class T>
struct GrowWithoutFill : std::allocator<T> {
  using value_type = T;
  using is_always_equal = std::true_type;
  template <class U>
  struct rebind {  // explicit: before C++20 std::allocator's own would rebind to itself
    using other = GrowWithoutFill<U>;
  };
  GrowWithoutFill() noexcept = default;
  template <class U>
  GrowWithoutFill(const GrowWithoutFill<U>&) noexcept {}

  // Default construction of a plain-data element (trivially copyable and destructible: an
  // implicit-lifetime type, which the allocation already created) writes nothing, default member
  // initialisers too (Float3's zeros): resize(n, {}) gives them.
  template <class U>
  void construct(U* p) noexcept(std::is_nothrow_default_constructible_v<U>) {
    if constexpr (!(std::is_trivially_copyable_v<U> && std::is_trivially_destructible_v<U>)) ::new (static_cast<void*>(p)) U();
  }
  template <class U, class... Args>
  void construct(U* p, Args&&... args) noexcept(std::is_nothrow_constructible_v<U, Args...>) {
    ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
  }
  template <class U>
  friend bool operator==(const GrowWithoutFill&, const GrowWithoutFill<U>&) noexcept {
    return true;
  }
};

template <class T>
using MeshArray = std::vector<T, GrowWithoutFill<T>>;

}  // namespace blobvk::mesh
