// The hashes mr uses: the splitmix64 finaliser (seeding, hash tables), and
// FNV-1a (mesh identity in .ffc files, content keys of mr-pipeline).
// Every one is fixed: stored hashes and seeded results depend on them.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>

namespace mr {

// 64-bit finaliser of splitmix64 (Steele et al. 2014): a bijective hash with
// good avalanche.
inline uint64_t MixBits(uint64_t v) {
  v ^= v >> 30;
  v *= 0xbf58476d1ce4e5b9ULL;
  v ^= v >> 27;
  v *= 0x94d049bb133111ebULL;
  v ^= v >> 31;
  return v;
}

inline constexpr uint64_t kGoldenGamma = 0x9e3779b97f4a7c15ULL;  // splitmix64's increment

// Hash of two integers, for seeding per (seed, pixel, frame, ...).
inline uint64_t HashCombine(uint64_t a, uint64_t b) {
  return MixBits(a ^ (MixBits(b) + kGoldenGamma + (a << 6) + (a >> 2)));
}

// FNV-1a, 64 bits.  Bytes() is the standard byte-at-a-time hash; Word()
// takes 8 bytes per step (a different, faster hash for large contents).
// Mixed() adds a final splitmix64 step for keys that need avalanche.
class Fnv1a {
 public:
  static constexpr uint64_t kOffset = 0xcbf29ce484222325ULL, kPrime = 0x100000001b3ULL;
  // `offset`: the offset basis (the standard one unless a stored format
  // fixed another).
  explicit Fnv1a(uint64_t offset = kOffset) : h_(offset) {}
  void Bytes(const void* p, size_t n) {
    const auto* c = static_cast<const unsigned char*>(p);
    for (size_t i = 0; i < n; ++i) h_ = (h_ ^ c[i]) * kPrime;
  }
  void Word(uint64_t w) { h_ = (h_ ^ w) * kPrime; }
  uint64_t value() const { return h_; }
  uint64_t Mixed() const { return MixBits(h_ + kGoldenGamma); }

 private:
  uint64_t h_;
};

// The standard FNV-1a of a string's bytes (keys of option strings and names).
inline uint64_t HashString(const std::string& s) {
  Fnv1a h;
  h.Bytes(s.data(), s.size());
  return h.value();
}

// Fnv1a over 64-bit words (bytes packed eight at a time, the tail's length
// mixed in), finished by MixBits: the content hashes of files (ContentHash).
struct Hasher {
  Fnv1a fnv;
  void Word(uint64_t w) { fnv.Word(w); }
  void Bytes(const char* p, size_t n) {
    size_t i = 0;
    for (; i + 8 <= n; i += 8) {
      uint64_t w;
      std::memcpy(&w, p + i, 8);
      Word(w);
    }
    uint64_t tail = 0;
    std::memcpy(&tail, p + i, n - i);
    Word(tail ^ (static_cast<uint64_t>(n - i) << 56));
  }
  void String(const std::string& s) {
    Word(s.size());
    Bytes(s.data(), s.size());
  }
  uint64_t Final() const { return fnv.Mixed(); }
};

}  // namespace mr
