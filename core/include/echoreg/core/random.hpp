// A small deterministic random generator whose streams do not depend on the standard library's
// distributions (those differ between implementations): same seed, same numbers, on any platform.
// Streams are derived from a seed and labels, so parallel work stays deterministic: each frame,
// shot or voxel block draws from its own stream, whatever thread runs it.
#pragma once

#include <cmath>
#include <cstdint>
#include <string_view>

namespace echoreg::core {

class Rng {
 public:
  explicit Rng(std::uint64_t seed = 0) {
    std::uint64_t s = seed;
    for (auto& word : state_)
      word = splitmix(s);
  }

  /// A generator for the stream named by (seed, label, index...): independent of draw order.
  static Rng derive(std::uint64_t seed, std::string_view label, std::uint64_t a = 0,
                    std::uint64_t b = 0) {
    std::uint64_t h = 0xcbf29ce484222325ULL ^ seed;
    for (char c : label)
      h = (h ^ static_cast<unsigned char>(c)) * 0x100000001b3ULL;
    std::uint64_t s = h;
    s ^= splitmix(h) + a * 0x9e3779b97f4a7c15ULL;
    s ^= splitmix(h) + b * 0xc2b2ae3d27d4eb4fULL;
    return Rng(s);
  }

  /// xoshiro256** (Blackman & Vigna 2018).
  std::uint64_t next() {
    const std::uint64_t result = rotl(state_[1] * 5, 7) * 9;
    const std::uint64_t t = state_[1] << 17;
    state_[2] ^= state_[0];
    state_[3] ^= state_[1];
    state_[1] ^= state_[2];
    state_[0] ^= state_[3];
    state_[2] ^= t;
    state_[3] = rotl(state_[3], 45);
    return result;
  }

  /// Uniform in [0, 1).
  double uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }
  double uniform(double low, double high) { return low + (high - low) * uniform(); }
  bool chance(double probability) { return uniform() < probability; }
  /// Uniform integer in [0, n).
  std::uint64_t below(std::uint64_t n) { return n == 0 ? 0 : next() % n; }

  /// Standard normal (Box-Muller, both values used).
  double normal() {
    if (hasSpare_) {
      hasSpare_ = false;
      return spare_;
    }
    double u = 0.0;
    do {
      u = uniform();
    } while (u <= 0.0);
    const double v = uniform();
    const double r = std::sqrt(-2.0 * std::log(u));
    constexpr double kTwoPi = 6.283185307179586476925;
    spare_ = r * std::sin(kTwoPi * v);
    hasSpare_ = true;
    return r * std::cos(kTwoPi * v);
  }
  double normal(double mean, double sigma) { return mean + sigma * normal(); }

 private:
  static std::uint64_t rotl(std::uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }
  static std::uint64_t splitmix(std::uint64_t& x) {
    std::uint64_t z = (x += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
  }

  std::uint64_t state_[4]{};
  double spare_ = 0.0;
  bool hasSpare_ = false;
};

}  // namespace echoreg::core
