#pragma once
/**
 * @file random.hpp
 * @brief Counter-based random streams: every pulse (or ray, or sample) gets its own generator
 *        seeded from (seed, sweep, index), so its noise does not depend on which thread drew
 *        it or on what other pulses did. Same seed, same numbers, bit for bit.
 */
#include <cmath>
#include <cstdint>

namespace avsp
{
namespace sensors
{
/// SplitMix64 finaliser (Steele, Lea and Flood 2014): a bijective 64-bit mix.
inline std::uint64_t mix64(std::uint64_t z)
{
  z += 0x9e3779b97f4a7c15ull;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}

/// Key of the stream for item `index` of sweep `sweep` under `seed`.
inline std::uint64_t streamKey(std::uint64_t seed, std::uint64_t sweep, std::uint64_t index)
{
  return mix64(mix64(mix64(seed) ^ sweep) ^ index);
}

/**
 * @brief A small generator for one item's draws (SplitMix64 sequence from its key).
 *
 * Normal deviates use Box-Muller without caching the second value, so each call consumes
 * exactly two uniforms: the draw sequence of an item is fixed by its code path alone.
 */
class StreamRng
{
public:
  explicit StreamRng(std::uint64_t key) : state_(key) {}

  std::uint64_t next()
  {
    state_ += 0x9e3779b97f4a7c15ull;
    std::uint64_t z = state_;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
  }

  /// Uniform in [0, 1), 53 random bits.
  double uniform() { return static_cast<double>(next() >> 11) * (1.0 / 9007199254740992.0); }

  /// Uniform in (0, 1]: safe under a logarithm.
  double uniformPositive() { return 1.0 - uniform(); }

  /// Standard normal deviate (Box-Muller, two uniforms).
  double normal()
  {
    const double u1 = uniformPositive(), u2 = uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(6.283185307179586 * u2);
  }

  /// Exponential deviate with rate `rate` (> 0), one uniform.
  double exponential(double rate) { return -std::log(uniformPositive()) / rate; }

private:
  std::uint64_t state_;
};

}  // namespace sensors
}  // namespace avsp
