// Uninitialised storage for large per-sample buffers (hundreds of MB), in
// transparent huge pages where the kernel offers them on request
// (/sys/kernel/mm/transparent_hugepage/enabled "madvise"): a 4 KiB page costs
// a fault of several microseconds on first touch in a VM, which for a 350 MB
// G-buffer was a tenth of a frame (docs/benchmarks.md).  T must be trivially
// destructible; the caller writes every element before reading it.
#pragma once

#include <cstddef>
#include <memory>
#include <type_traits>

namespace mr {

namespace detail {
// At least `bytes`, aligned to 2 MiB, advised as huge pages; throws
// std::bad_alloc.
void* AllocateLarge(size_t bytes);
void FreeLarge(void* p);
}  // namespace detail

template <class T>
class LargeBuffer {
  static_assert(std::is_trivially_destructible_v<T>);

 public:
  LargeBuffer() = default;
  // Holds at least n elements; their values are unspecified (kept from
  // before when the storage is reused).
  void Reserve(size_t n) {
    if (n <= capacity_) return;
    data_.reset(static_cast<T*>(detail::AllocateLarge(n * sizeof(T))));
    capacity_ = n;
  }
  T& operator[](size_t i) { return data_.get()[i]; }
  const T& operator[](size_t i) const { return data_.get()[i]; }

 private:
  struct Free {
    void operator()(T* p) const { detail::FreeLarge(p); }
  };
  std::unique_ptr<T, Free> data_;
  size_t capacity_ = 0;
};

}  // namespace mr
