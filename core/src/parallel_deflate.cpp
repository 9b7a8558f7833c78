#include "echoreg/core/parallel_deflate.hpp"

#include <zlib.h>

#include <algorithm>
#include <deque>
#include <future>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace echoreg::core {

namespace {

constexpr std::size_t kDictionaryBytes = 32768;  // deflate's window

struct Block {
  std::vector<std::uint8_t> deflated;
  uLong adler = 1;
  std::size_t bytes = 0;
};

// Block `index` of `blocks`: its input read with the 32 KiB before it as the dictionary, deflated
// raw and ended with a sync flush, or with the final block when it is the last.
Block deflateBlock(std::uint64_t totalBytes, std::size_t index, std::size_t blocks,
                   const DeflateReader& read, const ParallelDeflateOptions& options) {
  const std::uint64_t begin = static_cast<std::uint64_t>(index) * options.blockBytes;
  const std::uint64_t end = std::min<std::uint64_t>(begin + options.blockBytes, totalBytes);
  const std::size_t dictionary =
      static_cast<std::size_t>(std::min<std::uint64_t>(begin, kDictionaryBytes));
  Block block;
  block.bytes = static_cast<std::size_t>(end - begin);
  std::vector<std::uint8_t> input(dictionary + block.bytes);
  if (!input.empty())
    read(begin - dictionary, input.data(), input.size());
  const std::uint8_t* data = input.data() + dictionary;
  block.adler = adler32(1L, data, static_cast<uInt>(block.bytes));

  z_stream zs{};
  if (deflateInit2(&zs, options.level, Z_DEFLATED, -15, 8, Z_DEFAULT_STRATEGY) != Z_OK)
    throw std::runtime_error("zlib cannot start compressing");
  struct DeflateEnd {
    z_stream& zs;
    ~DeflateEnd() { deflateEnd(&zs); }
  } guard{zs};
  if (dictionary > 0 &&
      deflateSetDictionary(&zs, input.data(), static_cast<uInt>(dictionary)) != Z_OK) {
    throw std::runtime_error("zlib cannot take the block's dictionary");
  }
  const bool last = index + 1 == blocks;
  const int flush = last ? Z_FINISH : Z_SYNC_FLUSH;
  block.deflated.resize(deflateBound(&zs, static_cast<uLong>(block.bytes)) + 16);
  zs.next_in = const_cast<std::uint8_t*>(data);  // zlib's API is not const-correct
  zs.avail_in = static_cast<uInt>(block.bytes);
  std::size_t produced = 0;
  while (true) {
    zs.next_out = block.deflated.data() + produced;
    zs.avail_out = static_cast<uInt>(block.deflated.size() - produced);
    const int status = deflate(&zs, flush);
    if (status != Z_OK && status != Z_STREAM_END && status != Z_BUF_ERROR)
      throw std::runtime_error("zlib compression failed");
    produced = block.deflated.size() - zs.avail_out;
    // Done when the final block is out, or (sync flush) when all input is in and deflate left
    // room in the output (zlib's rule for a flush: repeat while it fills the output).
    if (last ? status == Z_STREAM_END : (zs.avail_in == 0 && zs.avail_out > 0))
      break;
    if (zs.avail_out == 0)
      block.deflated.resize(block.deflated.size() * 2);
  }
  block.deflated.resize(produced);
  return block;
}

}  // namespace

std::uint64_t deflateParallel(std::uint64_t totalBytes, const DeflateReader& read,
                              const DeflateWriter& write, const ParallelDeflateOptions& options) {
  if (options.level < 0 || options.level > 9)
    throw std::invalid_argument("deflateParallel: the level must be 0-9");
  if (options.blockBytes <= kDictionaryBytes || options.blockBytes > (std::size_t{1} << 30))
    throw std::invalid_argument(
        "deflateParallel: a block must be more than 32 KiB and at most 1 GiB");
  const std::size_t blocks = std::max<std::size_t>(
      1, static_cast<std::size_t>((totalBytes + options.blockBytes - 1) / options.blockBytes));
  const int threads = options.threads > 0
                          ? options.threads
                          : std::max(1, static_cast<int>(std::thread::hardware_concurrency()));

  // zlib's header for a 32 KiB window at this level (FLEVEL as deflate sets it), then the blocks,
  // then the Adler-32 of all the input, big-endian.
  const unsigned level = options.level < 2    ? 0u
                         : options.level < 6  ? 1u
                         : options.level == 6 ? 2u
                                              : 3u;
  unsigned header = (0x78u << 8) | (level << 6);
  header += 31u - header % 31u;
  const std::uint8_t head[2] = {static_cast<std::uint8_t>(header >> 8),
                                static_cast<std::uint8_t>(header & 0xffu)};
  write(head, 2);
  std::uint64_t written = 2;
  uLong adler = 1L;
  const auto take = [&](Block block) {
    write(block.deflated.data(), block.deflated.size());
    written += block.deflated.size();
    adler = adler32_combine(adler, block.adler, static_cast<z_off_t>(block.bytes));
  };
  if (threads == 1 || blocks == 1) {
    for (std::size_t i = 0; i < blocks; ++i)
      take(deflateBlock(totalBytes, i, blocks, read, options));
  } else {
    // Up to two blocks a thread in flight, so that the threads work while the writer writes.
    const std::size_t window = 2 * static_cast<std::size_t>(threads);
    std::deque<std::future<Block>> pending;
    std::size_t next = 0;
    while (next < blocks || !pending.empty()) {
      while (next < blocks && pending.size() < window) {
        pending.push_back(std::async(std::launch::async, deflateBlock, totalBytes, next, blocks,
                                     std::cref(read), std::cref(options)));
        ++next;
      }
      Block block = pending.front().get();
      pending.pop_front();
      take(std::move(block));
    }
  }
  const std::uint8_t tail[4] = {
      static_cast<std::uint8_t>(adler >> 24), static_cast<std::uint8_t>((adler >> 16) & 0xffu),
      static_cast<std::uint8_t>((adler >> 8) & 0xffu), static_cast<std::uint8_t>(adler & 0xffu)};
  write(tail, 4);
  return written + 4;
}

}  // namespace echoreg::core
