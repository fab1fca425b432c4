#pragma once
// Copies into results that are written once and not read again soon. On
// x86-64 the stores are non-temporal: they go to memory without the
// destination's lines being read into the cache first (ordinary stores
// read every line they write, doubling the memory traffic) and without
// evicting the rows being worked on. Elsewhere it is memcpy. Call
// stream_fence() before another thread may read what was written.

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#define PSRIG_STREAM_STORES 1
#endif

namespace psrig::processing {

#ifdef PSRIG_STREAM_STORES
namespace stream_detail {
// `lines` 64-byte lines from src to the line-aligned dst.
__attribute__((target("avx512f"))) inline void lines_avx512(char* dst, const char* src, std::size_t lines) {
  for (std::size_t i = 0; i < lines; ++i)
    _mm512_stream_si512(reinterpret_cast<__m512i*>(dst + 64 * i), _mm512_loadu_si512(src + 64 * i));
}
inline void lines_sse2(char* dst, const char* src, std::size_t lines) {
  for (std::size_t i = 0; i < 4 * lines; ++i)
    _mm_stream_si128(reinterpret_cast<__m128i*>(dst + 16 * i),
                     _mm_loadu_si128(reinterpret_cast<const __m128i*>(src + 16 * i)));
}
}  // namespace stream_detail

inline void stream_copy(void* dst, const void* src, std::size_t bytes) {
  static const bool avx512 = __builtin_cpu_supports("avx512f");
  auto* d = static_cast<char*>(dst);
  const auto* s = static_cast<const char*>(src);
  // Whole lines only; the partial ones at the ends take ordinary stores.
  const std::size_t head = std::min(bytes, (64 - reinterpret_cast<std::uintptr_t>(d) % 64) % 64);
  const std::size_t lines = (bytes - head) / 64;
  std::memcpy(d, s, head);
  if (avx512) stream_detail::lines_avx512(d + head, s + head, lines);
  else stream_detail::lines_sse2(d + head, s + head, lines);
  const std::size_t done = head + 64 * lines;
  std::memcpy(d + done, s + done, bytes - done);
}

// Non-temporal stores are weakly ordered: make them visible before the
// writer says it is done.
inline void stream_fence() { _mm_sfence(); }
#else
inline void stream_copy(void* dst, const void* src, std::size_t bytes) { std::memcpy(dst, src, bytes); }
inline void stream_fence() {}
#endif

}  // namespace psrig::processing
