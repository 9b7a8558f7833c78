// DICOM UIDs derived from a seed. Compiled into echoreg::simulation and into the DICOM module
// (dicom/CMakeLists.txt), whose writer names every file's instance with it.
#include "echoreg/core/random.hpp"
#include "echoreg/simulation/ct.hpp"

#include <array>
#include <cstdint>
#include <string>

namespace echoreg::simulation {

namespace {

/// A decimal string of the 128-bit number hi * 2^64 + lo.
std::string decimal128(std::uint64_t hi, std::uint64_t lo) {
  std::array<std::uint32_t, 4> limbs{
      static_cast<std::uint32_t>(hi >> 32), static_cast<std::uint32_t>(hi),
      static_cast<std::uint32_t>(lo >> 32), static_cast<std::uint32_t>(lo)};
  std::string digits;
  const auto isZero = [&limbs]() {
    return limbs[0] == 0 && limbs[1] == 0 && limbs[2] == 0 && limbs[3] == 0;
  };
  do {
    std::uint64_t remainder = 0;
    for (std::uint32_t& limb : limbs) {
      const std::uint64_t current = (remainder << 32) | limb;
      limb = static_cast<std::uint32_t>(current / 10);
      remainder = current % 10;
    }
    digits.insert(digits.begin(), static_cast<char>('0' + remainder));
  } while (!isZero());
  return digits;
}

}  // namespace

std::string derivedDicomUid(std::uint64_t uidSeed, const std::string& label, std::uint64_t index) {
  core::Rng rng = core::Rng::derive(uidSeed, "dicom-uid:" + label, index);
  std::uint64_t hi = 0;
  std::uint64_t lo = 0;
  while (hi == 0 && lo == 0) {
    hi = rng.next();
    lo = rng.next();
  }
  return "2.25." + decimal128(hi, lo);
}

}  // namespace echoreg::simulation
