#include "core/sampling.h"

#include <bit>

#include "core/lanes.h"

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

// ToUnit in lanes: the same value, bits * 2^-32 + low * 2^-53, each term
// and the sum exact, with an unsigned 32-bit to double conversion that
// vectorises (the integer's bits under 2^52's exponent, less 2^52).
inline double U32ToDouble(uint64_t x) { return std::bit_cast<double>(0x4330000000000000ULL | x) - 0x1p52; }
inline double ToUnitLanes(uint32_t bits, uint64_t low) {
  return U32ToDouble(bits) * 0x1p-32 + U32ToDouble(low & 0x1fffff) * 0x1p-53;
}

// Stratified1D and Stratified2D of n samplers at dimensions dim[k] + off.
MR_LANES void Draw1DLanes(int n, const uint64_t* __restrict seed, const uint32_t* __restrict rev,
                          const uint32_t* __restrict dim, uint32_t off, double* __restrict u) {
  for (int k = 0; k < n; ++k) {
    const uint64_t h = MixBits(seed[k] + static_cast<uint64_t>(dim[k] + off + 1) * kGoldenGamma);
    const uint32_t shuffled = ReverseBits32(LaineKarrasPermutation(rev[k], static_cast<uint32_t>(h)));
    u[k] = ToUnitLanes(ReverseBits32(LaineKarrasPermutation(shuffled, static_cast<uint32_t>(h >> 32))), MixBits(h));
  }
}

MR_LANES void Draw2DLanes(int n, const uint64_t* __restrict seed, const uint32_t* __restrict rev,
                          const uint32_t* __restrict dim, uint32_t off, double* __restrict u0, double* __restrict u1) {
  uint32_t shuffled[kLaneChunk], sobol[kLaneChunk];
  uint64_t h2s[kLaneChunk];
  for (int k = 0; k < n; ++k) {
    const uint64_t h = MixBits(seed[k] + static_cast<uint64_t>(dim[k] + off + 1) * kGoldenGamma);
    const uint64_t h2 = MixBits(h), low = MixBits(h2);
    const uint32_t sh = ReverseBits32(LaineKarrasPermutation(rev[k], static_cast<uint32_t>(h)));
    shuffled[k] = sh;
    h2s[k] = h2;
    u0[k] = ToUnitLanes(ReverseBits32(LaineKarrasPermutation(sh, static_cast<uint32_t>(h >> 32))), low);
  }
  for (int k = 0; k < n; ++k) sobol[k] = ReversedSobol1(shuffled[k]);  // a table: scalar loads
  for (int k = 0; k < n; ++k) {
    const uint64_t h2 = h2s[k];
    u1[k] = ToUnitLanes(ReverseBits32(LaineKarrasPermutation(sobol[k], static_cast<uint32_t>(h2))), MixBits(h2) >> 21);
  }
}

}  // namespace

void Sampler::DrawAhead(std::span<Sampler* const> samplers, std::span<const uint8_t> pattern,
                        std::vector<double>* values) {
  int per = 0;
  for (uint8_t p : pattern) {
    MR_CHECK(p == 1 || p == 2);
    per += p;
  }
  MR_CHECK(per <= 32);
  values->resize(samplers.size() * static_cast<size_t>(per));
  uint64_t seed[kLaneChunk];
  uint32_t rev[kLaneChunk], dim[kLaneChunk];
  double u0[kLaneChunk], u1[kLaneChunk];
  Sampler* lane[kLaneChunk];
  size_t used = 0;  // samplers given values so far
  for (size_t start = 0; start < samplers.size();) {
    int n = 0;
    for (; start < samplers.size() && n < static_cast<int>(kLaneChunk); ++start) {
      Sampler* s = samplers[start];
      if (!s->stratified_ || s->ahead_at_ < s->ahead_n_) continue;
      lane[n] = s;
      seed[n] = s->seed_;
      rev[n] = s->reversed_index_;
      dim[n] = s->dimension_;
      ++n;
    }
    double* base = values->data() + used * static_cast<size_t>(per);
    uint32_t off = 0, pairs = 0;
    for (uint8_t p : pattern) {
      if (p == 1) {
        Draw1DLanes(n, seed, rev, dim, off, u0);
        for (int k = 0; k < n; ++k) base[k * per + static_cast<int>(off)] = u0[k];
      } else {
        Draw2DLanes(n, seed, rev, dim, off, u0, u1);
        for (int k = 0; k < n; ++k) {
          base[k * per + static_cast<int>(off)] = u0[k];
          base[k * per + static_cast<int>(off) + 1] = u1[k];
        }
        pairs |= 1u << off;
      }
      off += p;
    }
    for (int k = 0; k < n; ++k) {
      lane[k]->ahead_ = base + k * per;
      lane[k]->dimension_ += off;
      lane[k]->ahead_n_ = static_cast<uint8_t>(off);
      lane[k]->ahead_at_ = 0;
      lane[k]->ahead_pairs_ = pairs;
    }
    used += static_cast<size_t>(n);
  }
}

void Sampler::DropAhead() {
  dimension_ -= static_cast<uint32_t>(ahead_n_ - ahead_at_);
  ahead_ = nullptr;
  ahead_n_ = ahead_at_ = 0;
  ahead_pairs_ = 0;
}

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

namespace {

// Concentric (Shirley-Chiu) disk mapping, then lift to the hemisphere; no
// branch, so that lanes of it vectorise (core/lanes.h).
inline void CosineHemisphere(double u0, double u1, double* x, double* y, double* z) {
  const double ox = 2.0 * u0 - 1.0, oy = 2.0 * u1 - 1.0;
  const bool wide = std::abs(ox) > std::abs(oy);
  const double r = wide ? ox : oy, other = wide ? oy : ox;
  const double ratio = other / (r == 0 ? 1.0 : r);
  const double theta = wide ? (kPi / 4) * ratio : kPi / 2 - (kPi / 4) * ratio;
  double s, c;
  SinCos(theta, &s, &c);
  const double dx = r * c, dy = r * s;  // r = 0 at the centre: (0, 0)
  *x = dx;
  *y = dy;
  *z = std::sqrt(std::max(0.0, 1.0 - dx * dx - dy * dy));
}

}  // namespace

std::array<double, 3> SampleCosineHemisphere(double u0, double u1) {
  std::array<double, 3> d;
  CosineHemisphere(u0, u1, &d[0], &d[1], &d[2]);
  return d;
}

MR_LANES void SampleCosineHemisphere(size_t n, const double* __restrict u0, const double* __restrict u1,
                                     double* __restrict x, double* __restrict y, double* __restrict z) {
  for (size_t k = 0; k < n; ++k) CosineHemisphere(u0[k], u1[k], &x[k], &y[k], &z[k]);
}

}  // namespace mr
