// Random numbers that are the same on every standard library: std::mt19937_64's output sequence is
// fixed by the C++ standard, but std::uniform_real_distribution and std::normal_distribution are
// implementation-defined, so the procedural scenes and the degradations draw their variates from
// the raw engine output here. ROS-free, header-only.
#pragma once

#include <cmath>
#include <cstdint>
#include <random>

namespace stereo_safety_map {
namespace dataset {

/// SplitMix64 finaliser: decorrelates nearby seeds (seed, seed + 1, ...) before they seed an
/// engine.
inline std::uint64_t mixSeed(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

class PortableRng {
 public:
  explicit PortableRng(std::uint64_t seed) : engine_(mixSeed(seed)) {}

  std::uint64_t raw() { return engine_(); }
  /// Uniform in [0, 1) with 53 random bits.
  double uniform() { return static_cast<double>(engine_() >> 11) * (1.0 / 9007199254740992.0); }
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  /// Standard normal (Box-Muller; one of the pair, so each call uses two engine outputs).
  double normal() {
    const double u1 = (static_cast<double>(engine_() >> 11) + 1.0) * (1.0 / 9007199254740993.0);
    const double u2 = uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
  }
  /// Integer in [lo, hi] (inclusive).
  int integer(int lo, int hi) {
    if (hi <= lo) return lo;
    const int n = hi - lo + 1;
    const int k = static_cast<int>(uniform() * n);
    return lo + (k < n ? k : n - 1);
  }
  bool chance(double p) { return uniform() < p; }
  double sign() { return chance(0.5) ? 1.0 : -1.0; }

 private:
  std::mt19937_64 engine_;
};

}  // namespace dataset
}  // namespace stereo_safety_map
