// The environment light's harmonics: projection and evaluation agree with
// direct integration over the sphere, for the cosine lobe and for the
// fibre's Kajiya-Kay lobe, and an equirectangular map lands the right way up.

#include "psrig/preview/environment_light.h"

#include <cmath>
#include <numbers>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

namespace psrig::preview {
namespace {

constexpr double kPiDouble = std::numbers::pi;

// Integral over the sphere of radiance(w) * kernel(w), by a fine grid.
template <class Radiance, class Kernel>
Eigen::Vector3d integrate(Radiance radiance, Kernel kernel) {
  constexpr int kRows = 400, kColumns = 800;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (int row = 0; row < kRows; ++row) {
    const double polar = (row + 0.5) * kPiDouble / kRows;
    const double area = std::sin(polar) * (kPiDouble / kRows) * (2 * kPiDouble / kColumns);
    for (int column = 0; column < kColumns; ++column) {
      const double longitude = (column + 0.5) * 2 * kPiDouble / kColumns;
      const Eigen::Vector3f w(static_cast<float>(std::sin(polar) * std::cos(longitude)),
                              static_cast<float>(std::cos(polar)),
                              static_cast<float>(std::sin(polar) * std::sin(longitude)));
      sum += radiance(w).template cast<double>() * kernel(w) * area;
    }
  }
  return sum;
}

// A sky made of the second-order harmonics only: the projection keeps it
// whole, so its convolutions are exact.
Eigen::Vector3f smooth_sky(const Eigen::Vector3f& w) {
  return {1.0f + 0.5f * w.y() + 0.3f * w.x() * w.z(), 0.8f + 0.2f * w.z() - 0.25f * w.x() * w.y(),
          0.6f + 0.4f * (3 * w.y() * w.y() - 1) / 2};
}

TEST(EnvironmentLight, LambertAndFibreLobesMatchDirectIntegration) {
  // The sky as a dense lat-long image, projected as from a file.
  cv::Mat image(180, 360, CV_32FC3);
  for (int row = 0; row < image.rows; ++row)
    for (int column = 0; column < image.cols; ++column) {
      const double polar = (row + 0.5) * kPiDouble / image.rows;
      const double longitude = (column + 0.5) * 2 * kPiDouble / image.cols - kPiDouble;
      const Eigen::Vector3f w(static_cast<float>(std::sin(polar) * std::sin(longitude)),
                              static_cast<float>(std::cos(polar)),
                              static_cast<float>(std::sin(polar) * std::cos(longitude)));
      const Eigen::Vector3f rgb = smooth_sky(w);
      image.at<cv::Vec3f>(row, column) = {rgb.z(), rgb.y(), rgb.x()};  // BGR
    }
  const EnvironmentLight light = EnvironmentLight::from_equirectangular(image);
  for (const Eigen::Vector3f& direction :
       {Eigen::Vector3f(0, 1, 0), Eigen::Vector3f(0.6f, 0, 0.8f), Eigen::Vector3f(-0.48f, -0.6f, 0.64f)}) {
    const Eigen::Vector3f n = direction.normalized();
    const Eigen::Vector3d lambert =
        integrate(smooth_sky, [&](const Eigen::Vector3f& w) { return std::max(0.0f, n.dot(w)); }) /
        kPiDouble;
    const Eigen::Vector3d fibre =
        integrate(smooth_sky,
                  [&](const Eigen::Vector3f& w) {
                    return std::sqrt(std::max(0.0f, 1 - n.dot(w) * n.dot(w)));
                  }) /
        (kPiDouble * kPiDouble);
    EXPECT_TRUE(light.lambert(n).cast<double>().isApprox(lambert, 5e-3))
        << light.lambert(n).transpose() << " vs " << lambert.transpose();
    EXPECT_TRUE(light.fibre(n).cast<double>().isApprox(fibre, 5e-3))
        << light.fibre(n).transpose() << " vs " << fibre.transpose();
    EXPECT_TRUE(light.radiance(n).isApprox(smooth_sky(n), 5e-3f));
  }
}

TEST(EnvironmentLight, UniformSkyGivesItsRadianceEverywhere) {
  const EnvironmentLight sky = EnvironmentLight::uniform({0.2f, 0.3f, 0.4f});
  for (const Eigen::Vector3f& w : {Eigen::Vector3f(1, 0, 0), Eigen::Vector3f(0, -0.6f, 0.8f)}) {
    EXPECT_TRUE(sky.lambert(w).isApprox(Eigen::Vector3f(0.2f, 0.3f, 0.4f), 1e-4f));
    EXPECT_TRUE(sky.fibre(w).isApprox(Eigen::Vector3f(0.2f, 0.3f, 0.4f), 1e-4f));
  }
  EXPECT_EQ(EnvironmentLight{}.lambert(Eigen::Vector3f::UnitZ()), Eigen::Vector3f::Zero());
}

TEST(EnvironmentLight, LobeAndImageAgreeOnWhereTheLightIs) {
  // One broad lobe overhead (+y), as lobes and as an 8-bit sRGB image with
  // +y at the top: both light a face looking up more than one looking down.
  const RadialLobe lobe{Eigen::Vector3f::UnitY(), 2, {1, 1, 1}};
  const EnvironmentLight from_lobes = EnvironmentLight::from_lobes({lobe});
  cv::Mat image(64, 128, CV_8UC3, cv::Scalar::all(0));
  image.rowRange(0, 16).setTo(cv::Scalar::all(255));
  const EnvironmentLight from_image = EnvironmentLight::from_equirectangular(image);
  for (const EnvironmentLight* light : {&from_lobes, &from_image}) {
    EXPECT_GT(light->lambert(Eigen::Vector3f::UnitY()).x(),
              5 * light->lambert(-Eigen::Vector3f::UnitY()).x());
    EXPECT_NEAR(light->lambert(Eigen::Vector3f::UnitX()).x(),
                light->lambert(Eigen::Vector3f::UnitZ()).x(), 1e-3f)
        << "symmetric about the vertical";
  }
  // A fibre lying horizontal sees the overhead light broadside; one standing
  // up sees it end on.
  EXPECT_GT(from_lobes.fibre(Eigen::Vector3f::UnitX()).x(),
            from_lobes.fibre(Eigen::Vector3f::UnitY()).x());
}

TEST(EnvironmentLight, StudioIsAboutTheOldAmbientFromTheFront) {
  const Eigen::Vector3f front = EnvironmentLight::studio().lambert(Eigen::Vector3f::UnitZ());
  EXPECT_GT(front.minCoeff(), 0.1f);
  EXPECT_LT(front.maxCoeff(), 0.4f);
}

}  // namespace
}  // namespace psrig::preview
