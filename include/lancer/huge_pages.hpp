// Large arrays on transparent huge pages. Where the kernel gives them only on request
// (/sys/kernel/mm/transparent_hugepage/enabled = madvise, the default of many distributions
// and of these VMs), every 4 KiB page of a fresh array costs a fault: at one million spheres the
// hierarchy's build touched 180 MB, 46000 faults, a third of its time on a VM (docs/accel.md,
// fourteenth round). Embree's allocator asks for huge pages too (madvise(MADV_HUGEPAGE)).
#pragma once

#include <cstddef>
#include <new>
#include <type_traits>
#include <vector>

namespace lancer {

// From this size on, an allocation is its own mapping, 2 MiB aligned and advised as huge pages.
inline constexpr std::size_t kHugePageBytes = std::size_t(2) << 20;

// Memory for `bytes` (>= 1) aligned to `align` (a power of two <= 4096); std::bad_alloc if none.
// Below kHugePageBytes: operator new. Free with release_memory(p, bytes, align), the same values.
void* acquire_memory(std::size_t bytes, std::size_t align);
void release_memory(void* p, std::size_t bytes, std::size_t align) noexcept;

// For a buffer someone else allocated (a std::vector's reserve) and about to be written in full:
// advises the whole 2 MiB pages within [p, p + bytes) as huge pages, then populates the range
// in one call (MADV_POPULATE_WRITE, Linux 5.14) instead of a fault per page. Large malloc blocks
// are mappings of their own, so the advice stays with the buffer. Only advice: where the system
// refuses it, the pages come as they would have.
void prepare_pages(const void* p, std::size_t bytes) noexcept;

// v.reserve(n), its buffer's pages prepared for the n elements about to be written.
template <class Vector>
void reserve_prepared(Vector& v, std::size_t n) {
  v.reserve(n);
  prepare_pages(v.data(), n * sizeof(typename Vector::value_type));
}

// A standard allocator over acquire_memory: std::vector<T, HugePageAllocator<T>> is a vector
// whose large buffers sit on huge pages where the system has them (a plain mapping elsewhere).
template <class T>
struct HugePageAllocator {
  using value_type = T;
  HugePageAllocator() = default;
  template <class U>
  HugePageAllocator(const HugePageAllocator<U>&) noexcept {}
  T* allocate(std::size_t n) {
    if (n > std::size_t(-1) / sizeof(T)) throw std::bad_alloc();
    return static_cast<T*>(acquire_memory(n * sizeof(T), alignof(T)));
  }
  void deallocate(T* p, std::size_t n) noexcept { release_memory(p, n * sizeof(T), alignof(T)); }
  template <class U>
  bool operator==(const HugePageAllocator<U>&) const noexcept {
    return true;
  }
  template <class U>
  bool operator!=(const HugePageAllocator<U>&) const noexcept {
    return false;
  }
};

template <class T>
using BigVector = std::vector<T, HugePageAllocator<T>>;

// n uninitialised T (trivial types), on huge pages when large. Pages never written are never
// faulted in: for a bound of which only a part is used (the build's node slots).
template <class T>
class BigArray {
  static_assert(std::is_trivially_default_constructible_v<T> && std::is_trivially_destructible_v<T>,
                "BigArray holds trivial types only: nothing is constructed or destroyed");

 public:
  explicit BigArray(std::size_t n) : n_(n), p_(HugePageAllocator<T>().allocate(n ? n : 1)) {}
  ~BigArray() { HugePageAllocator<T>().deallocate(p_, n_ ? n_ : 1); }
  BigArray(const BigArray&) = delete;
  BigArray& operator=(const BigArray&) = delete;
  T& operator[](std::size_t i) { return p_[i]; }
  const T& operator[](std::size_t i) const { return p_[i]; }
  std::size_t size() const { return n_; }

 private:
  std::size_t n_;
  T* p_;
};

}  // namespace lancer
