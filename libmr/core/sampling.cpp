#include "core/sampling.h"

namespace mr {

uint32_t Pcg32::NextBounded(uint32_t bound) {
  MR_CHECK_GT(bound, 0u);
  uint32_t threshold = (~bound + 1u) % bound;
  for (;;) {
    uint32_t r = NextU32();
    if (r >= threshold) return r % bound;
  }
}

void Pcg32::Advance(int64_t idelta) {
  uint64_t cur_mult = 6364136223846793005ULL, cur_plus = inc_, acc_mult = 1u, acc_plus = 0u;
  uint64_t delta = static_cast<uint64_t>(idelta);
  while (delta > 0) {
    if (delta & 1) {
      acc_mult *= cur_mult;
      acc_plus = acc_plus * cur_mult + cur_plus;
    }
    cur_plus = (cur_mult + 1) * cur_plus;
    cur_mult *= cur_mult;
    delta /= 2;
  }
  state_ = acc_mult * state_ + acc_plus;
}

namespace {
constexpr int kPrimes[64] = {2,   3,   5,   7,   11,  13,  17,  19,  23,  29,  31,  37,  41,  43,  47,  53,
                             59,  61,  67,  71,  73,  79,  83,  89,  97,  101, 103, 107, 109, 113, 127, 131,
                             137, 139, 149, 151, 157, 163, 167, 173, 179, 181, 191, 193, 197, 199, 211, 223,
                             227, 229, 233, 239, 241, 251, 257, 263, 269, 271, 277, 281, 283, 293, 307, 311};

inline uint32_t ReverseBits32(uint32_t n) {
  n = __builtin_bswap32(n);
  n = ((n & 0x0f0f0f0f) << 4) | ((n & 0xf0f0f0f0) >> 4);
  n = ((n & 0x33333333) << 2) | ((n & 0xcccccccc) >> 2);
  n = ((n & 0x55555555) << 1) | ((n & 0xaaaaaaaa) >> 1);
  return n;
}

// Laine-Karras permutation on a bit-reversed value: nested uniform scramble.
uint32_t LaineKarrasPermutation(uint32_t x, uint32_t seed) {
  x += seed;
  x ^= x * 0x6c50b47cu;
  x ^= x * 0xb82f1e52u;
  x ^= x * 0xc7afe638u;
  x ^= x * 0x8d22f6e6u;
  return x;
}

uint32_t OwenScramble(uint32_t v, uint32_t seed) {
  return ReverseBits32(LaineKarrasPermutation(ReverseBits32(v), seed));
}

// Sobol' dimension 1, bit-reversed, one byte of the index at
// a time: kSobol1Reversed[k][b] is the reversed point of index b << 8k.
struct Sobol1Tables {
  uint32_t t[4][256];
  Sobol1Tables() {
    uint32_t dir[32];
    dir[0] = 1u << 31;
    for (int k = 1; k < 32; ++k) dir[k] = dir[k - 1] ^ (dir[k - 1] >> 1);
    for (int k = 0; k < 4; ++k)
      for (uint32_t b = 0; b < 256; ++b) {
        uint32_t v = 0;
        for (int bit = 0; bit < 8; ++bit)
          if (b & (1u << bit)) v ^= dir[8 * k + bit];
        t[k][b] = ReverseBits32(v);
      }
  }
};
const Sobol1Tables kSobol1Reversed;

inline uint32_t ReversedSobol1(uint32_t i) {
  const auto& t = kSobol1Reversed.t;
  return t[0][i & 255] ^ t[1][(i >> 8) & 255] ^ t[2][(i >> 16) & 255] ^ t[3][i >> 24];
}

}  // namespace

double RadicalInverse(int dimension, uint64_t index) {
  MR_CHECK(dimension >= 0 && dimension < 64);
  const uint64_t base = static_cast<uint64_t>(kPrimes[dimension]);
  const double inv_base = 1.0 / static_cast<double>(base);
  double inv_base_m = 1.0;
  uint64_t reversed = 0;
  // Accumulate digits as an integer while it cannot overflow, as pbrt does.
  while (index) {
    uint64_t next = index / base;
    uint64_t digit = index - next * base;
    reversed = reversed * base + digit;
    inv_base_m *= inv_base;
    index = next;
  }
  return std::min(static_cast<double>(reversed) * inv_base_m, 0x1.fffffffffffffp-1);
}

std::array<float, 2> Sobol2D(uint32_t index, uint32_t seed, bool scramble) {
  // Dimension 0: van der Corput (generator matrix = identity, bit-reversed).
  uint32_t v0 = ReverseBits32(index);
  // Dimension 1: primitive polynomial x + 1, direction numbers v_k = 2^(32-k)
  // combined by v_k = v_{k-1} ^ (v_{k-1} >> 1) (Sobol1Tables).
  uint32_t v1 = ReverseBits32(ReversedSobol1(index));
  if (scramble) {
    uint64_t h = MixBits(seed);
    v0 = OwenScramble(v0, static_cast<uint32_t>(h));
    v1 = OwenScramble(v1, static_cast<uint32_t>(h >> 32));
  }
  // 24 bits so that the float never rounds up to 1.
  return {static_cast<float>(v0 >> 8) * 0x1p-24f, static_cast<float>(v1 >> 8) * 0x1p-24f};
}

namespace {

// 32 scrambled bits and 21 random ones below them (the infinite scramble's
// deeper digits): uniform in [0, 1).
inline double ToUnit(uint32_t bits, uint64_t low) {
  return static_cast<double>((static_cast<uint64_t>(bits) << 21) | (low & 0x1fffff)) * 0x1p-53;
}

}  // namespace

// With R the bit reversal and S_k the Laine-Karras permutation under seed k
// (an Owen scramble of a reversed value), a draw's shuffled index is
// i' = R S_a R i, its van der Corput point R i' scrambled is R S_b R R i' =
// R S_b i', and its Sobol' dimension-1 point P(i') scrambled is
// R S_c R P(i').  R i is kept (reversed_index_), so a 1D draw costs two
// reversals and a 2D draw three.
Sampler Sampler::Stratified(uint64_t seed, uint32_t index) {
  Sampler s;
  s.stratified_ = true;
  s.seed_ = MixBits(seed);
  s.index_ = index;
  s.reversed_index_ = ReverseBits32(index);
  return s;
}

double Sampler::Stratified1D() {
  const uint64_t h = MixBits(seed_ + (dimension_++ + 1) * kGoldenGamma);
  const uint32_t shuffled = ReverseBits32(LaineKarrasPermutation(reversed_index_, static_cast<uint32_t>(h)));
  const uint64_t low = MixBits(h);
  return ToUnit(ReverseBits32(LaineKarrasPermutation(shuffled, static_cast<uint32_t>(h >> 32))), low);
}

std::array<double, 2> Sampler::Stratified2D() {
  const uint64_t h = MixBits(seed_ + (dimension_ + 1) * kGoldenGamma);
  dimension_ += 2;
  const uint64_t h2 = MixBits(h), low = MixBits(h2);
  const uint32_t shuffled = ReverseBits32(LaineKarrasPermutation(reversed_index_, static_cast<uint32_t>(h)));
  return {
      ToUnit(ReverseBits32(LaineKarrasPermutation(shuffled, static_cast<uint32_t>(h >> 32))), low),
      ToUnit(ReverseBits32(LaineKarrasPermutation(ReversedSobol1(shuffled), static_cast<uint32_t>(h2))), low >> 21)};
}

std::array<double, 3> SampleUniformSphere(double u0, double u1) {
  double z = 1.0 - 2.0 * u0;
  double r = SafeSqrt(1.0 - z * z);
  double phi = kTwoPi * u1;
  return {r * std::cos(phi), r * std::sin(phi), z};
}

std::array<double, 3> SampleCosineHemisphere(double u0, double u1) {
  // Concentric (Shirley-Chiu) disk mapping, then lift to the hemisphere.
  double ox = 2.0 * u0 - 1.0, oy = 2.0 * u1 - 1.0;
  double dx = 0, dy = 0;
  if (ox != 0 || oy != 0) {
    double r, theta;
    if (std::abs(ox) > std::abs(oy)) {
      r = ox;
      theta = (kPi / 4) * (oy / ox);
    } else {
      r = oy;
      theta = kPi / 2 - (kPi / 4) * (ox / oy);
    }
    dx = r * std::cos(theta);
    dy = r * std::sin(theta);
  }
  double z = SafeSqrt(1.0 - dx * dx - dy * dy);
  return {dx, dy, z};
}

}  // namespace mr
