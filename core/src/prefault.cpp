#include "echoreg/core/prefault.hpp"

#include <sys/mman.h>
#include <unistd.h>

namespace echoreg::core {

void prefaultForWriting(void* data, std::size_t bytes) {
#ifdef MADV_POPULATE_WRITE
  const long pageBytes = ::sysconf(_SC_PAGESIZE);
  if (data == nullptr || pageBytes <= 0 || bytes == 0)
    return;
  const auto page = static_cast<std::uintptr_t>(pageBytes);
  const auto start = reinterpret_cast<std::uintptr_t>(data);
  const std::uintptr_t first = (start + page - 1) / page * page;
  const std::uintptr_t end = (start + bytes) / page * page;
  if (end <= first)
    return;
#ifdef MADV_HUGEPAGE
  // Where the kernel leaves transparent huge pages to madvise (Debian's default), ask for them on
  // the whole 2 MiB pages inside the range: one fault (or one populate step) maps 2 MiB instead
  // of 4 KiB. Reading a 37 MB capture's samples took 110-150 ms with 4 KiB pages on this
  // machine's VM and 8-15 ms with huge pages (docs/benchmarks.md). Refused or unavailable huge
  // pages change nothing but the speed.
  constexpr std::uintptr_t kHugePage = std::uintptr_t{2} << 20;
  const std::uintptr_t hugeFirst = (start + kHugePage - 1) / kHugePage * kHugePage;
  const std::uintptr_t hugeEnd = (start + bytes) / kHugePage * kHugePage;
  if (hugeEnd > hugeFirst)
    ::madvise(reinterpret_cast<void*>(hugeFirst), hugeEnd - hugeFirst, MADV_HUGEPAGE);
#endif
  ::madvise(reinterpret_cast<void*>(first), end - first, MADV_POPULATE_WRITE);
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

}  // namespace echoreg::core
