#pragma once
// Results are written once and not read again soon, so the three-light
// solve streams them out with non-temporal stores: these go to memory
// without the destination lines being read into the cache first (ordinary
// stores read every line they write, doubling the traffic) and without
// evicting the rows being worked on. A RowStream copies a result row from
// a scratch row, in cache, to its destination a line at a time while the
// scratch row is being filled, so the stores spread over the arithmetic
// instead of stalling it at the end of the row.
//
// Lines::copy moves one 64-byte line. The AVX ones have to be inlined into
// code compiled for that ISA (woodham.cpp's multiversioned row solvers).
// Elsewhere than x86-64 it is memcpy.

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#define PSRIG_STREAM_STORES 1
#endif

namespace psrig::processing {

struct CopyLines {
  static void copy(char* dst, const char* src) { std::memcpy(dst, src, 64); }
};

#ifdef PSRIG_STREAM_STORES
struct StreamLinesSse2 {  // baseline x86-64
  static void copy(char* dst, const char* src) {
    for (int i = 0; i < 64; i += 16)
      _mm_stream_si128(reinterpret_cast<__m128i*>(dst + i),
                       _mm_loadu_si128(reinterpret_cast<const __m128i*>(src + i)));
  }
};
struct StreamLinesAvx {
  __attribute__((target("avx"))) static void copy(char* dst, const char* src) {
    for (int i = 0; i < 64; i += 32)
      _mm256_stream_si256(reinterpret_cast<__m256i*>(dst + i),
                          _mm256_loadu_si256(reinterpret_cast<const __m256i*>(src + i)));
  }
};
struct StreamLinesAvx512 {
  __attribute__((target("avx512f"))) static void copy(char* dst, const char* src) {
    _mm512_stream_si512(reinterpret_cast<__m512i*>(dst), _mm512_loadu_si512(src));
  }
};

// Non-temporal stores are weakly ordered: make them visible before the
// writer says it is done.
inline void stream_fence() {
  _mm_sfence();
}
#else
inline void stream_fence() {}
#endif

// One row: `bytes` at dst, copied from src as src is completed. The partial
// lines at either end (shared with the neighbouring rows) take ordinary
// stores.
template <class Lines>
class RowStream {
 public:
  RowStream(void* dst, const void* src, std::size_t bytes)
      : dst_(static_cast<char*>(dst)),
        src_(static_cast<const char*>(src)),
        bytes_(bytes),
        head_(std::min(bytes, (64 - reinterpret_cast<std::uintptr_t>(dst) % 64) % 64)),
        done_(head_) {}

  // The first `ready` bytes of src are final: send the whole lines among them.
  void advance(std::size_t ready) {
    ready = std::min(ready, bytes_);
    for (; done_ + 64 <= ready; done_ += 64)
      Lines::copy(dst_ + done_, src_ + done_);
  }

  void finish() {
    advance(bytes_);
    std::memcpy(dst_, src_, head_);
    std::memcpy(dst_ + done_, src_ + done_, bytes_ - done_);
  }

 private:
  char* dst_;
  const char* src_;
  std::size_t bytes_, head_, done_;
};

}  // namespace psrig::processing
