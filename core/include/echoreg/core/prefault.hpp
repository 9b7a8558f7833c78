// Mapping fresh memory in one call rather than one page fault per page.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace echoreg::core {

/// Asks the kernel to map the whole pages of [data, data + bytes) writable now
/// (MADV_POPULATE_WRITE, Linux 5.14), instead of one page fault per 4 KB page when they are first
/// written: a capture's samples and a block of envelopes are megabytes, and on the virtual
/// machines echoreg runs on a page fault costs microseconds (docs/benchmarks.md). The contents
/// are unchanged (pages not yet mapped read as zeros). The whole 2 MiB pages inside the range are
/// first advised as transparent huge pages (MADV_HUGEPAGE), so that they are mapped 2 MiB at a
/// time. Where the kernel refuses either, nothing changes but the speed.
void prefaultForWriting(void* data, std::size_t bytes);

/// `bytes` zero bytes, their pages mapped by prefaultForWriting before the zero-fill touches them.
std::vector<std::uint8_t> prefaultedZeros(std::size_t bytes);

/// For a short process that allocates and first-touches tens of megabytes in many blocks (a
/// detection's per-frame tables, strings and envelope blocks): grows the malloc heap by `bytes`
/// now, advises it as transparent huge pages (MADV_HUGEPAGE) and keeps it (glibc's mmap and trim
/// thresholds raised), so that what the process allocates later is mapped 2 MiB per page fault
/// instead of 4 KiB. Nothing is touched here: memory that is never used costs address space only.
/// With glibc only; elsewhere, or where the kernel refuses, nothing changes but the speed.
void reserveHugePageHeap(std::size_t bytes);

}  // namespace echoreg::core
