#include "echoreg/core/prefault.hpp"

#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace echoreg::core {

#ifdef MADV_POPULATE_WRITE
namespace {

// madvise `advice` on the whole `unit`-aligned units inside [start, start + bytes), if any.
void adviseWholeUnits(std::uintptr_t start, std::size_t bytes, std::uintptr_t unit, int advice) {
  const std::uintptr_t first = (start + unit - 1) / unit * unit;
  const std::uintptr_t end = (start + bytes) / unit * unit;
  if (end > first)
    ::madvise(reinterpret_cast<void*>(first), end - first, advice);
}

}  // namespace
#endif

void prefaultForWriting(void* data, std::size_t bytes) {
#ifdef MADV_POPULATE_WRITE
  const long pageBytes = ::sysconf(_SC_PAGESIZE);
  if (data == nullptr || pageBytes <= 0 || bytes == 0)
    return;
  const auto start = reinterpret_cast<std::uintptr_t>(data);
#ifdef MADV_HUGEPAGE
  // Where the kernel leaves transparent huge pages to madvise (Debian's default), ask for them on
  // the whole 2 MiB pages inside the range: one fault (or one populate step) maps 2 MiB instead
  // of 4 KiB. Reading a 37 MB capture's samples took 110-150 ms with 4 KiB pages on this
  // machine's VM and 8-15 ms with huge pages (docs/benchmarks.md). Refused or unavailable huge
  // pages change nothing but the speed.
  adviseWholeUnits(start, bytes, std::uintptr_t{2} << 20, MADV_HUGEPAGE);
#endif
  adviseWholeUnits(start, bytes, static_cast<std::uintptr_t>(pageBytes), MADV_POPULATE_WRITE);
#else
  (void)data;
  (void)bytes;
#endif
}

std::vector<std::uint8_t> prefaultedZeros(std::size_t bytes) {
  std::vector<std::uint8_t> buffer;
  buffer.reserve(bytes);
  prefaultForWriting(buffer.data(), bytes);
  buffer.resize(bytes);
  return buffer;
}

void reserveHugePageHeap(std::size_t bytes) {
#if defined(__GLIBC__) && defined(MADV_HUGEPAGE) && defined(MADV_POPULATE_WRITE)
  if (bytes == 0)
    return;
  // Blocks up to 32 MiB (glibc's largest mmap threshold on 64-bit) come from the heap rather than
  // mappings of their own, and the heap is not given back while the process runs.
  constexpr int kMmapThreshold = 32 << 20;
  if (::mallopt(M_MMAP_THRESHOLD, kMmapThreshold) == 0 ||
      ::mallopt(M_TRIM_THRESHOLD, static_cast<int>(std::min<std::size_t>(bytes * 2, 1U << 30))) ==
          0) {
    return;
  }
  const auto start = reinterpret_cast<std::uintptr_t>(::sbrk(0));
  // One block below the threshold grows the heap by that much; freed, it stays in the heap.
  const std::size_t block = std::min<std::size_t>(bytes, kMmapThreshold - 4096);
  void* grow = std::malloc(block);
  std::free(grow);
  const auto end = reinterpret_cast<std::uintptr_t>(::sbrk(0));
  if (grow == nullptr || end <= start)
    return;
  adviseWholeUnits(start, end - start, std::uintptr_t{2} << 20, MADV_HUGEPAGE);
#else
  (void)bytes;
#endif
}

}  // namespace echoreg::core
