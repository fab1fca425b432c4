#pragma once
// The calibration targets (sphere, ChArUco card, colour chart) are drawn
// this many samples per pixel along each axis, then averaged, so that
// their edges fall between pixels as a real target's do.

namespace psrig::sim {

inline constexpr int kSamplesPerPixel = 4;

}  // namespace psrig::sim
