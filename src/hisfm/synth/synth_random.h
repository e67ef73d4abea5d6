// Deterministic random numbers for the synthetic scenes.
//
// The generator must produce the same scene for the same --seed on every
// platform and for any number of threads. std::mt19937 is fully specified by
// the C++ standard, but the std:: distributions are not, so the conversions to
// uniform and normal variates are done here. Every independent stream (scene
// layout, one image, one image pair) gets its own seed derived with
// DeriveSeed, so results do not depend on the order of evaluation.
#pragma once

#include <cmath>
#include <cstdint>
#include <random>

namespace hisfm {

/// Mixes a base seed with up to two stream keys (SplitMix64 finaliser) into a
/// 32-bit seed for std::mt19937.
inline uint32_t DeriveSeed(uint64_t seed, uint64_t key1, uint64_t key2 = 0) {
  uint64_t z = seed * 0x9E3779B97F4A7C15ULL + key1 * 0xBF58476D1CE4E5B9ULL +
               key2 * 0x94D049BB133111EBULL + 0x2545F4914F6CDD1DULL;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  z ^= z >> 31;
  return static_cast<uint32_t>(z ^ (z >> 32));
}

/// A std::mt19937 with platform-independent uniform and normal variates.
class SynthRandom {
 public:
  explicit SynthRandom(uint32_t seed) : engine_(seed) {}

  /// Uniform in [0, 1) with 32 bits of resolution.
  double Uniform() { return engine_() * (1.0 / 4294967296.0); }
  /// Uniform in [a, b).
  double Uniform(double a, double b) { return a + (b - a) * Uniform(); }
  /// Uniform integer in [0, n) (n > 0); the bias for n << 2^32 is negligible.
  uint32_t UniformInt(uint32_t n) {
    return static_cast<uint32_t>(Uniform() * n) % n;
  }
  /// True with probability p.
  bool Bernoulli(double p) { return Uniform() < p; }
  /// Standard normal variate (Box-Muller, one value per call).
  double Normal() {
    const double u1 = 1.0 - Uniform();  // in (0, 1]
    const double u2 = Uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
  }
  /// Normal variate with mean 0 and standard deviation sigma.
  double Normal(double sigma) { return sigma * Normal(); }

 private:
  std::mt19937 engine_;
};

}  // namespace hisfm
