#include "lancer/huge_pages.hpp"

#include <sys/mman.h>
#include <unistd.h>

#include <cstdint>

namespace lancer {

namespace {

std::size_t round_up(std::size_t bytes, std::size_t to) { return (bytes + to - 1) / to * to; }

}  // namespace

void* acquire_memory(std::size_t bytes, std::size_t align) {
  if (bytes < kHugePageBytes) return ::operator new(bytes, std::align_val_t(align));
  const std::size_t size = round_up(bytes, kHugePageBytes);
  if (size < bytes || size > std::size_t(-1) - kHugePageBytes) throw std::bad_alloc();
  // Map 2 MiB more than needed, keep the 2 MiB aligned part: a huge page needs an aligned range.
  void* raw = mmap(nullptr, size + kHugePageBytes, PROT_READ | PROT_WRITE,
                   MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  if (raw == MAP_FAILED) throw std::bad_alloc();
  const auto start = reinterpret_cast<std::uintptr_t>(raw);
  const std::uintptr_t aligned = round_up(start, kHugePageBytes);
  if (aligned > start) munmap(raw, aligned - start);
  const std::size_t tail = kHugePageBytes - (aligned - start);
  if (tail > 0) munmap(reinterpret_cast<void*>(aligned + size), tail);
  void* p = reinterpret_cast<void*>(aligned);
#ifdef MADV_HUGEPAGE
  madvise(p, size, MADV_HUGEPAGE);  // advice: refused (no THP) leaves 4 KiB pages, still correct
#endif
  return p;
}

void prepare_pages(const void* p, std::size_t bytes) noexcept {
  const auto start = reinterpret_cast<std::uintptr_t>(p);
  if (bytes < kHugePageBytes) return;
#ifdef MADV_HUGEPAGE
  const std::uintptr_t lo = round_up(start, kHugePageBytes);
  const std::uintptr_t hi = (start + bytes) / kHugePageBytes * kHugePageBytes;
  if (hi > lo) madvise(reinterpret_cast<void*>(lo), hi - lo, MADV_HUGEPAGE);
#endif
#ifdef MADV_POPULATE_WRITE
  // One call for the pages a fault each would bring in (on a VM each fault is a costly exit).
  const std::uintptr_t page = std::uintptr_t(sysconf(_SC_PAGESIZE));
  const std::uintptr_t first = start / page * page, last = round_up(start + bytes, page);
  madvise(reinterpret_cast<void*>(first), last - first, MADV_POPULATE_WRITE);
#endif
}

void release_memory(void* p, std::size_t bytes, std::size_t align) noexcept {
  if (bytes < kHugePageBytes) return ::operator delete(p, std::align_val_t(align));
  munmap(p, round_up(bytes, kHugePageBytes));
}

}  // namespace lancer
