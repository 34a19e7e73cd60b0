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

uint32_t ReverseBits32(uint32_t n) {
  n = (n << 16) | (n >> 16);
  n = ((n & 0x00ff00ff) << 8) | ((n & 0xff00ff00) >> 8);
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
  // combined by v_k = v_{k-1} ^ (v_{k-1} >> 1).
  uint32_t v1 = 0;
  uint32_t dir = 1u << 31;
  for (uint32_t i = index; i; i >>= 1) {
    if (i & 1) v1 ^= dir;
    dir ^= dir >> 1;
  }
  if (scramble) {
    uint64_t h = MixBits(seed);
    v0 = OwenScramble(v0, static_cast<uint32_t>(h));
    v1 = OwenScramble(v1, static_cast<uint32_t>(h >> 32));
  }
  // 24 bits so that the float never rounds up to 1.
  return {static_cast<float>(v0 >> 8) * 0x1p-24f, static_cast<float>(v1 >> 8) * 0x1p-24f};
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
