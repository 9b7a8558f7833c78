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
  if (end > first)
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
