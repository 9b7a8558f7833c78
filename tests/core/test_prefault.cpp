// prefaultForWriting maps pages ahead of their first write without changing what they hold.
#include "echoreg/core/prefault.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <vector>

namespace {

TEST(Prefault, KeepsWhatTheMemoryHolds) {
  // 3 MB and an odd offset, so that the range starts and ends inside pages.
  std::vector<std::uint8_t> buffer(3u << 20);
  for (std::size_t i = 0; i < buffer.size(); ++i)
    buffer[i] = static_cast<std::uint8_t>(i * 131u + 7u);
  const std::vector<std::uint8_t> before = buffer;
  echoreg::core::prefaultForWriting(buffer.data() + 3, buffer.size() - 5);
  EXPECT_EQ(buffer, before);
  echoreg::core::prefaultForWriting(nullptr, 4096);
  echoreg::core::prefaultForWriting(buffer.data(), 0);
  EXPECT_EQ(buffer, before);
}

TEST(Prefault, ZerosAreZerosOfTheSizeAsked) {
  for (const std::size_t bytes :
       {std::size_t{0}, std::size_t{1}, std::size_t{4095}, std::size_t{(8u << 20) + 17u}}) {
    const std::vector<std::uint8_t> zeros = echoreg::core::prefaultedZeros(bytes);
    ASSERT_EQ(zeros.size(), bytes);
    EXPECT_TRUE(std::all_of(zeros.begin(), zeros.end(), [](std::uint8_t b) { return b == 0; }))
        << bytes << " bytes";
  }
}

// The heap grown and advised for huge pages keeps serving allocations, and what the heap already
// held is unchanged by it (advice that dropped pages would read them back as zeros).
TEST(Prefault, AHugePageHeapKeepsServingAndKeepsWhatItHolds) {
  std::vector<std::vector<std::uint32_t>> blocks;
  const auto fill = [](std::vector<std::uint32_t>& block, std::uint32_t seed) {
    for (std::size_t i = 0; i < block.size(); ++i)
      block[i] = static_cast<std::uint32_t>(i) * 2654435761u + seed;
  };
  const auto holds = [](const std::vector<std::uint32_t>& block, std::uint32_t seed) {
    for (std::size_t i = 0; i < block.size(); ++i) {
      if (block[i] != static_cast<std::uint32_t>(i) * 2654435761u + seed)
        return false;
    }
    return true;
  };
  for (const std::size_t n : {std::size_t{1}, std::size_t{1000}, std::size_t{1} << 18}) {
    blocks.emplace_back(n);
    fill(blocks.back(), static_cast<std::uint32_t>(n));
  }
  echoreg::core::reserveHugePageHeap(std::size_t{16} << 20);
  echoreg::core::reserveHugePageHeap(0);
  for (const std::size_t n : {std::size_t{7}, std::size_t{5000}, std::size_t{3} << 20}) {
    blocks.emplace_back(n);
    fill(blocks.back(), static_cast<std::uint32_t>(n));
  }
  echoreg::core::reserveHugePageHeap(std::size_t{4} << 20);  // again: harmless
  for (const auto& block : blocks)
    EXPECT_TRUE(holds(block, static_cast<std::uint32_t>(block.size()))) << block.size();
}

}  // namespace
