// One zlib stream (RFC 1950) compressed on several threads, as pigz does: the input is cut into
// blocks of a fixed size, each block is deflated on its own thread (raw deflate, primed with the
// 32 KiB before it as its dictionary, so matches reach back across the cut as in one stream) and
// ended with a sync flush (an empty stored block: byte-aligned, not final), the last one with the
// final block; the blocks are written in order between zlib's 2-byte header and the Adler-32 of
// all the input (combined from the blocks' own). The result is one valid zlib stream that any
// inflater reads whole (zlib's inflate, MetaIO's reader in VTK/ITK/3D Slicer), and the same bytes
// whatever the number of threads: the blocks and their dictionaries do not depend on it. Input
// of at most one block gives zlib's own one-shot output byte for byte.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>

namespace echoreg::core {

struct ParallelDeflateOptions {
  int level = 1;                                  ///< zlib's level, 0-9
  std::size_t blockBytes = std::size_t{4} << 20;  ///< input per block (> 32 KiB)
  int threads = 0;                                ///< 0: the machine's hardware threads
};

/// Reads `bytes` bytes of the input at `offset` into `out` (called from several threads at once,
/// for disjoint or overlapping ranges; must throw on failure).
using DeflateReader =
    std::function<void(std::uint64_t offset, std::uint8_t* out, std::size_t bytes)>;
/// Takes the next piece of the compressed stream (called on the calling thread, in order).
using DeflateWriter = std::function<void(const std::uint8_t* data, std::size_t bytes)>;

/// Compresses the `totalBytes` bytes `read` gives into one zlib stream handed to `write`; returns
/// the compressed size. Memory: per thread one input block and two output blocks (about 12 MiB a
/// thread at the default block size). Throws std::invalid_argument for a bad level or block size,
/// std::runtime_error when zlib fails, and what `read` or `write` throw.
std::uint64_t deflateParallel(std::uint64_t totalBytes, const DeflateReader& read,
                              const DeflateWriter& write,
                              const ParallelDeflateOptions& options = {});

}  // namespace echoreg::core
