// Random and quasi-random numbers that make runs deterministic.
//
// Every pixel, cache record, VPL or form-factor vertex seeds its own
// generator from (global seed, index): results depend on neither the thread
// count nor the order in which work is scheduled (docs/conventions.md).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>

#include "core/hash.h"
#include "core/math.h"

namespace mr {

// PCG32 (O'Neill 2014, pcg32_random_r): 64-bit state, 2^63 selectable streams.
class Pcg32 {
 public:
  // `seed` picks the position, `stream` the sequence; use (global seed,
  // record index) so that each record has an independent stream.
  explicit Pcg32(uint64_t seed = 0x853c49e6748fea9bULL, uint64_t stream = 0xda3e39cb94b95bdbULL) { Seed(seed, stream); }

  void Seed(uint64_t seed, uint64_t stream) {
    state_ = 0u;
    inc_ = (stream << 1u) | 1u;
    NextU32();
    state_ += seed;
    NextU32();
  }

  uint32_t NextU32() {
    uint64_t old = state_;
    state_ = old * 6364136223846793005ULL + inc_;
    uint32_t xorshifted = static_cast<uint32_t>(((old >> 18u) ^ old) >> 27u);
    uint32_t rot = static_cast<uint32_t>(old >> 59u);
    return (xorshifted >> rot) | (xorshifted << ((~rot + 1u) & 31));
  }

  // Uniform in [0, 1): 24 random bits, so never rounds up to 1.
  float NextFloat() { return static_cast<float>(NextU32() >> 8) * 0x1p-24f; }
  // Uniform in [0, 1) with 53 random bits.
  double NextDouble() {
    uint64_t hi = NextU32(), lo = NextU32();
    return static_cast<double>(((hi << 32) | lo) >> 11) * 0x1p-53;
  }
  // Uniform integer in [0, bound) without modulo bias.
  uint32_t NextBounded(uint32_t bound);

  // Jumps ahead (or back, for negative delta) in O(log delta).
  void Advance(int64_t delta);

  bool operator==(const Pcg32&) const = default;

 private:
  uint64_t state_ = 0, inc_ = 0;
};

// A standard normal deviate (Box-Muller, one of the pair).
inline double NextGaussian(Pcg32& rng) {
  const double u1 = std::max(1e-300, rng.NextDouble()), u2 = rng.NextDouble();
  return std::sqrt(-2 * std::log(u1)) * std::cos(6.283185307179586 * u2);
}

// Radical inverse of `index` in a prime base; dimension d uses the d-th prime
// (d < 64).  Halton point i = (RadicalInverse(0, i), RadicalInverse(1, i), ...).
double RadicalInverse(int dimension, uint64_t index);

// The first two dimensions of the Sobol sequence, optionally Owen-scrambled
// by a hash of `seed` (Laine-Karras style nested uniform scrambling).  A
// (0,2)-sequence in base 2: every 2^k prefix is stratified.
std::array<float, 2> Sobol2D(uint32_t index, uint32_t seed = 0, bool scramble = false);

// Maps a point of [0,1)^2 to directions, with pdfs in solid angle.
// The vectors are (x, y, z) with z the pole.
std::array<double, 3> SampleUniformSphere(double u0, double u1);
std::array<double, 3> SampleCosineHemisphere(double u0, double u1);  // pdf cos/pi
inline constexpr double kUniformSpherePdf = 1.0 / kFourPi;

}  // namespace mr
