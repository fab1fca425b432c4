#pragma once
// Synthetic photometric-stereo scenes with a known answer, built in memory:
// analytic surfaces rendered Lambertian under lights at the rig's geometry.

#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "psrig/formats/scan.h"

namespace psrig::test {

// `count` lights evenly spread in tilt from `first_tilt_deg` (0, 120, 240 for
// three), all at `slant_deg` from the camera axis (docs/design.md "Axes and units").
[[nodiscard]] std::vector<cv::Vec3d> ring_lights(int count, double slant_deg,
                                                 double first_tilt_deg = 0);

struct Surface {
  cv::Mat normal;  // CV_32FC3 unit (nx, ny, nz), camera axes
  cv::Mat albedo;  // CV_32FC(channels), BGR for colour
};

// A sphere of `radius` pixels in the middle of a flat plane, with an albedo
// that varies smoothly (and differently per channel, for colour).
[[nodiscard]] Surface sphere_surface(cv::Size size, double radius, int channels);

// A hemispherical dome of `radius` pixels standing on a plane in the middle
// of the image: unit normals, and for a light the CV_8U mask (255) of the
// plane pixels in the dome's cast shadow (exact ray-sphere test).
[[nodiscard]] Surface dome_surface(cv::Size size, double radius, int channels);
[[nodiscard]] cv::Mat dome_cast_shadow(cv::Size size, double radius, const cv::Vec3d& light);

// `count` lights spread evenly (a Fibonacci spiral) over the cap of the
// sphere of directions within `max_slant_deg` of the camera axis, as on a
// light dome (DiLiGenT's 96 lights reach about 50 degrees).
[[nodiscard]] std::vector<cv::Vec3d> dome_lights(int count, double max_slant_deg);

// A bumpy plane: height z = amplitude sin(2 pi x / period) sin(2 pi y / period)
// (pixels), its unit normals, an albedo as sphere_surface's, and its height in `height`.
[[nodiscard]] Surface bumpy_surface(cv::Size size, double amplitude, double period, int channels,
                                    cv::Mat* height = nullptr);
// The CV_8U mask (255) of the pixels of height field `height` (pixels,
// CV_32F) that another part of it hides from `light` (marching the ray).
[[nodiscard]] cv::Mat height_cast_shadow(const cv::Mat& height, const cv::Vec3d& light);

// A glossy surface's lobe added to the Lambertian term: Blinn-Phong,
// strength * (n.h)^exponent with h the half vector of the light and the
// view (+z), where n.l > 0 and the light is not blocked.
struct Specular {
  double strength = 0;
  double exponent = 1;
};

// Frames of `surface` under `lights`: albedo * max(0, n.l) * intensity,
// plus Gaussian noise of `noise` (fraction of full scale), quantised to
// `depth` (CV_8U, CV_16U or CV_32F). The scan carries the ground-truth
// normals, and `description` is filled so solve() can run on it.
// Where `shadows[k]` is given and nonzero, light k is blocked.
[[nodiscard]] formats::Scan render_scan(const Surface& surface,
                                        const std::vector<cv::Vec3d>& lights, int depth,
                                        double noise = 0, std::uint64_t seed = 1,
                                        const std::vector<cv::Mat>& shadows = {},
                                        Specular specular = {});

// The RMS angle error (radians) photometric stereo makes at a pixel of
// normal n and grey albedo rho, under Gaussian noise sigma (fraction of full
// scale) per channel in each of `channels`: cov(t) = sigma^2 / channels
// (L^T L)^-1, and only the part across n turns the normal, so
// E[theta^2] = sigma^2 / (channels rho^2) tr(P (L^T L)^-1 P), P = I - n n^T.
[[nodiscard]] double predicted_rms_angle(const std::vector<cv::Vec3d>& lights, const cv::Vec3d& n,
                                         double rho, double sigma, int channels);

// The naive rule --reject must beat: per pixel, drop the darkest quarter
// and the brightest sixth of the values (n / 4 and n / 6 of n lights,
// rounded down), then least squares. Straight from the frames over the
// white level, less the dark frame (no flats or intensities): unit normals, CV_32FC3,
// (0, 0, 0) where it has no answer.
[[nodiscard]] cv::Mat naive_rule_normals(const formats::Scan& scan);

// Mean angle in degrees between two normal maps over the pixels where
// `select` is nonzero (all pixels when empty).
[[nodiscard]] double mean_angular_error_deg(const cv::Mat& a, const cv::Mat& b,
                                            const cv::Mat& select = {});

}  // namespace psrig::test
