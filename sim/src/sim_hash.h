#pragma once
// Deterministic hashing and value noise for the simulated world. Everything
// random in a swatch is a pure function of (seed, lattice coordinates), so the
// same seed gives the same swatch bit for bit, whatever the thread count.

#include <cmath>
#include <cstdint>

namespace psrig::sim::detail {

// The splitmix64 finaliser: a cheap, well-mixed 64-bit hash.
[[nodiscard]] constexpr std::uint64_t mix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

[[nodiscard]] constexpr std::uint64_t hash_of(std::uint64_t key, std::int64_t a, std::int64_t b = 0,
                                              std::int64_t c = 0) {
  std::uint64_t h = mix64(key ^ mix64(static_cast<std::uint64_t>(a)));
  h = mix64(h ^ static_cast<std::uint64_t>(b));
  return mix64(h ^ static_cast<std::uint64_t>(c));
}

// Uniform in [-1, 1).
[[nodiscard]] constexpr double signed_unit(std::uint64_t h) {
  return static_cast<double>(h >> 11) * 0x1.0p-52 - 1.0;
}

// A uniform number in [-1, 1) for one (key, a, b, c).
[[nodiscard]] constexpr double jitter(std::uint64_t key, std::int64_t a, std::int64_t b = 0,
                                      std::int64_t c = 0) {
  return signed_unit(hash_of(key, a, b, c));
}

// Value noise in [-1, 1] on the integer lattice, C1 through a quintic fade;
// one hash per corner keeps it cheap enough to run per pixel.
[[nodiscard]] inline float value_noise(float x, float y, std::uint64_t key) {
  const float fx = std::floor(x);
  const float fy = std::floor(y);
  const auto ix = static_cast<std::int64_t>(fx);
  const auto iy = static_cast<std::int64_t>(fy);
  const auto corner = [key](std::int64_t cx, std::int64_t cy) {
    const std::uint64_t h = mix64(key ^ (static_cast<std::uint64_t>(cx) * 0x9E3779B97F4A7C15ull) ^
                                  (static_cast<std::uint64_t>(cy) * 0xC2B2AE3D27D4EB4Full));
    return static_cast<float>(h >> 40) * 0x1.0p-23f - 1.0f;
  };
  const auto fade = [](float t) { return t * t * t * (t * (t * 6.0f - 15.0f) + 10.0f); };
  const float u = fade(x - fx);
  const float v = fade(y - fy);
  const float top = corner(ix, iy) + u * (corner(ix + 1, iy) - corner(ix, iy));
  const float bottom = corner(ix, iy + 1) + u * (corner(ix + 1, iy + 1) - corner(ix, iy + 1));
  return top + v * (bottom - top);
}

}  // namespace psrig::sim::detail
