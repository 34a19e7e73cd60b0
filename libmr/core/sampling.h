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
#include <span>
#include <vector>

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

// The random numbers of one path: either independent (PCG32) or one sample
// of a stratified sequence (Owen-scrambled Sobol', Burley 2020, "Practical
// Hash-based Owen Scrambling").
//
// Stratified: a pixel's samples 0..N-1 are points of a sequence seeded by
// the pixel; every call draws a fresh dimension (1D) or pair of dimensions
// (2D).  Each draw's dimensions are shuffled apart from every other draw's
// by Owen-scrambling the sample index with a hash of (seed, dimension), so
// that, per draw, the first 2^m samples are stratified: in 1D one point in
// each interval of length 2^-m, in 2D a (0,m,2)-net (one point in each
// elementary box 2^-a x 2^-(m-a)), and draws are decorrelated from each
// other.  Each point is uniformly distributed on its own (the estimates
// stay unbiased); 32 bits come from the scrambled sequence, the 21 below
// them from a hash (the infinite scramble's deeper digits).
//
// Paths that must stay aligned (the real and the mixed path parting at a
// virtual object) copy the Sampler: the copy continues at the same
// dimension.  Independent mode draws exactly what a Pcg32 would.
class Sampler {
 public:
  static Sampler Random(uint64_t seed, uint64_t stream) {
    Sampler s;
    s.pcg_.Seed(seed, stream);
    return s;
  }
  static Sampler Stratified(uint64_t seed, uint32_t index);
  double NextDouble() {
    if (ahead_at_ < ahead_n_) return TakeAhead(false);
    return stratified_ ? Stratified1D() : pcg_.NextDouble();
  }
  // Two values meant to be used together (a point on the pixel, the lens, a
  // light, a BSDF lobe): a 2D-stratified pair.
  std::array<double, 2> Next2D() {
    if (ahead_at_ < ahead_n_) {
      const double u0 = TakeAhead(true);
      return {u0, ahead_[ahead_at_++]};
    }
    if (stratified_) return Stratified2D();
    const double u0 = pcg_.NextDouble();
    return {u0, pcg_.NextDouble()};
  }
  bool stratified() const { return stratified_; }
  bool operator==(const Sampler&) const = default;

  // Draws in lanes.  `pattern` lists the draws each of `samplers` makes
  // next, in order (1: NextDouble, 2: Next2D); they are computed for all
  // the samplers at once (SIMD over samplers, core/lanes.h) into *values
  // (which must outlive them: the samplers point into it), so that each
  // sampler's own NextDouble and Next2D return them: the same numbers in
  // the same order as drawing one by one.  Only stratified samplers with
  // nothing ahead take part (the others draw as they go).  The draws that
  // follow must be the pattern's (checked in debug builds); at most 32
  // values.
  static void DrawAhead(std::span<Sampler* const> samplers, std::span<const uint8_t> pattern,
                        std::vector<double>* values);
  // The values ahead from `offset` on (the pattern's in order): what the
  // coming draws will return, before they are drawn; null if none.
  const double* Ahead(int offset) const {
    return ahead_at_ + offset < ahead_n_ ? ahead_ + ahead_at_ + offset : nullptr;
  }
  // Forgets the values ahead not drawn, and steps back their dimensions,
  // as if they had never been drawn.
  void DropAhead();

 private:
  double Stratified1D();
  std::array<double, 2> Stratified2D();
  double TakeAhead(bool pair) {
    MR_DCHECK(((ahead_pairs_ >> ahead_at_) & 1) == static_cast<uint32_t>(pair));
    return ahead_[ahead_at_++];
  }
  Pcg32 pcg_;
  uint64_t seed_ = 0;
  uint32_t index_ = 0, reversed_index_ = 0, dimension_ = 0;
  bool stratified_ = false;
  const double* ahead_ = nullptr;  // DrawAhead's values for this sampler
  uint8_t ahead_n_ = 0, ahead_at_ = 0;
  uint32_t ahead_pairs_ = 0;  // bit i: a pair starts at ahead_[i]
};

// Maps a point of [0,1)^2 to directions, with pdfs in solid angle.
// The vectors are (x, y, z) with z the pole.
std::array<double, 3> SampleUniformSphere(double u0, double u1);
std::array<double, 3> SampleCosineHemisphere(double u0, double u1);  // pdf cos/pi
// The same for n points in lanes (core/lanes.h), the same bits.
void SampleCosineHemisphere(size_t n, const double* u0, const double* u1, double* x, double* y, double* z);
inline constexpr double kUniformSpherePdf = 1.0 / kFourPi;

}  // namespace mr
