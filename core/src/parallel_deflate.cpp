#include "echoreg/core/parallel_deflate.hpp"

#include <zlib.h>

#include <algorithm>
#include <condition_variable>
#include <exception>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace echoreg::core {

namespace {

constexpr std::size_t kDictionaryBytes = 32768;  // deflate's window

// A raw deflate stream kept for the blocks of one thread: initialised once, reset per block (a
// fresh stream and fresh buffers per block cost 1.8 times the CPU of one stream, most of it the
// kernel's page faults on new memory).
class BlockDeflater {
 public:
  explicit BlockDeflater(int level) {
    if (deflateInit2(&zs_, level, Z_DEFLATED, -15, 8, Z_DEFAULT_STRATEGY) != Z_OK)
      throw std::runtime_error("zlib cannot start compressing");
  }
  ~BlockDeflater() { deflateEnd(&zs_); }
  BlockDeflater(const BlockDeflater&) = delete;
  BlockDeflater& operator=(const BlockDeflater&) = delete;

  // Deflates `bytes` at `data` after the `dictionary` bytes before it into `out` (grown as
  // needed, never shrunk); ended with a sync flush, or with the final block when `last`. Returns
  // the compressed size.
  std::size_t deflateBlock(const std::uint8_t* dictionary, std::size_t dictionaryBytes,
                           const std::uint8_t* data, std::size_t bytes, bool last,
                           std::vector<std::uint8_t>& out) {
    if (deflateReset(&zs_) != Z_OK)
      throw std::runtime_error("zlib cannot restart compressing");
    if (dictionaryBytes > 0 &&
        deflateSetDictionary(&zs_, dictionary, static_cast<uInt>(dictionaryBytes)) != Z_OK) {
      throw std::runtime_error("zlib cannot take the block's dictionary");
    }
    const std::size_t bound = deflateBound(&zs_, static_cast<uLong>(bytes)) + 16;
    if (out.size() < bound)
      out.resize(bound);
    const int flush = last ? Z_FINISH : Z_SYNC_FLUSH;
    zs_.next_in = const_cast<std::uint8_t*>(data);  // zlib's API is not const-correct
    zs_.avail_in = static_cast<uInt>(bytes);
    std::size_t produced = 0;
    while (true) {
      zs_.next_out = out.data() + produced;
      zs_.avail_out = static_cast<uInt>(out.size() - produced);
      const int status = deflate(&zs_, flush);
      if (status != Z_OK && status != Z_STREAM_END && status != Z_BUF_ERROR)
        throw std::runtime_error("zlib compression failed");
      produced = out.size() - zs_.avail_out;
      // Done when the final block is out, or (sync flush) when all input is in and deflate left
      // room in the output (zlib's rule for a flush: repeat while it fills the output).
      if (last ? status == Z_STREAM_END : (zs_.avail_in == 0 && zs_.avail_out > 0))
        return produced;
      if (zs_.avail_out == 0)
        out.resize(out.size() * 2);
    }
  }

 private:
  z_stream zs_{};
};

// One block of the stream: its input range and, once deflated, its bytes and Adler-32.
struct Slot {
  std::size_t index = 0;
  enum class State { Free, Queued, Working, Done } state = State::Free;
  std::vector<std::uint8_t> deflated;  ///< reused from block to block
  std::size_t deflatedBytes = 0;
  uLong adler = 1;
  std::size_t bytes = 0;
  std::exception_ptr error;
};

// Reads block `slot.index` (with the 32 KiB before it) into `input` and deflates it into `slot`.
void deflateSlot(Slot& slot, std::uint64_t totalBytes, std::size_t blocks,
                 const DeflateReader& read, std::size_t blockBytes, BlockDeflater& deflater,
                 std::vector<std::uint8_t>& input) {
  const std::uint64_t begin = static_cast<std::uint64_t>(slot.index) * blockBytes;
  const std::uint64_t end = std::min<std::uint64_t>(begin + blockBytes, totalBytes);
  const std::size_t dictionary =
      static_cast<std::size_t>(std::min<std::uint64_t>(begin, kDictionaryBytes));
  slot.bytes = static_cast<std::size_t>(end - begin);
  if (input.size() < dictionary + slot.bytes)
    input.resize(dictionary + slot.bytes);
  if (dictionary + slot.bytes > 0)
    read(begin - dictionary, input.data(), dictionary + slot.bytes);
  const std::uint8_t* data = input.data() + dictionary;
  slot.adler = adler32(1L, data, static_cast<uInt>(slot.bytes));
  slot.deflatedBytes = deflater.deflateBlock(input.data(), dictionary, data, slot.bytes,
                                             slot.index + 1 == blocks, slot.deflated);
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
  // At most 8 threads by default: beyond that the disk, not deflate, sets the pace of a
  // recording's end, and every thread holds about 12 MiB.
  const int threads = options.threads > 0
                          ? options.threads
                          : std::clamp(static_cast<int>(std::thread::hardware_concurrency()), 1, 8);

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
  const auto take = [&](const Slot& slot) {
    write(slot.deflated.data(), slot.deflatedBytes);
    written += slot.deflatedBytes;
    adler = adler32_combine(adler, slot.adler, static_cast<z_off_t>(slot.bytes));
  };
  if (threads == 1 || blocks == 1) {
    BlockDeflater deflater(options.level);
    std::vector<std::uint8_t> input;
    Slot slot;
    for (std::size_t i = 0; i < blocks; ++i) {
      slot.index = i;
      deflateSlot(slot, totalBytes, blocks, read, options.blockBytes, deflater, input);
      take(slot);
    }
  } else {
    // `threads` workers, each with its own stream and input buffer, deflate the blocks of a
    // window of 2 per thread (slot i % window holds block i), so that they work while this
    // thread writes the finished blocks in order.
    const std::size_t window = 2 * static_cast<std::size_t>(threads);
    std::vector<Slot> slots(std::min(window, blocks));
    std::mutex mutex;
    std::condition_variable changed;
    bool stop = false;
    std::exception_ptr startError;
    for (std::size_t i = 0; i < slots.size(); ++i) {
      slots[i].index = i;
      slots[i].state = Slot::State::Queued;
    }
    const auto work = [&] {
      try {
        BlockDeflater deflater(options.level);
        std::vector<std::uint8_t> input;
        std::unique_lock<std::mutex> lock(mutex);
        while (true) {
          Slot* slot = nullptr;
          changed.wait(lock, [&] {
            if (stop)
              return true;
            for (Slot& s : slots) {
              if (s.state == Slot::State::Queued) {
                slot = &s;
                return true;
              }
            }
            return false;
          });
          if (stop)
            return;
          slot->state = Slot::State::Working;
          lock.unlock();
          try {
            deflateSlot(*slot, totalBytes, blocks, read, options.blockBytes, deflater, input);
          } catch (...) {
            slot->error = std::current_exception();
          }
          lock.lock();
          slot->state = Slot::State::Done;
          changed.notify_all();
        }
      } catch (...) {
        // The worker's stream could not start (zlib's memory): the writer stops with it.
        const std::lock_guard<std::mutex> lock(mutex);
        if (!startError)
          startError = std::current_exception();
        changed.notify_all();
      }
    };
    std::vector<std::thread> workers;
    struct Join {
      std::vector<std::thread>& workers;
      std::mutex& mutex;
      std::condition_variable& changed;
      bool& stop;
      ~Join() {
        {
          const std::lock_guard<std::mutex> lock(mutex);
          stop = true;
        }
        changed.notify_all();
        for (std::thread& t : workers)
          t.join();
      }
    } join{workers, mutex, changed, stop};
    for (int t = 0; t < threads; ++t)
      workers.emplace_back(work);
    for (std::size_t i = 0; i < blocks; ++i) {
      Slot& slot = slots[i % slots.size()];
      {
        std::unique_lock<std::mutex> lock(mutex);
        changed.wait(lock, [&] { return slot.state == Slot::State::Done || startError; });
        if (startError)
          std::rethrow_exception(startError);
      }
      if (slot.error)
        std::rethrow_exception(slot.error);
      take(slot);
      const std::lock_guard<std::mutex> lock(mutex);
      if (i + slots.size() < blocks) {
        slot.index = i + slots.size();
        slot.state = Slot::State::Queued;
        changed.notify_all();
      } else {
        slot.state = Slot::State::Free;
      }
    }
  }
  const std::uint8_t tail[4] = {
      static_cast<std::uint8_t>(adler >> 24), static_cast<std::uint8_t>((adler >> 16) & 0xffu),
      static_cast<std::uint8_t>((adler >> 8) & 0xffu), static_cast<std::uint8_t>(adler & 0xffu)};
  write(tail, 4);
  return written + 4;
}

}  // namespace echoreg::core
