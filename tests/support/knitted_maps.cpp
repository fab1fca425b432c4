#include "knitted_maps.h"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "psrig/cloth/knit_fabric.h"
#include "psrig/cloth/yarn_raster.h"

namespace psrig::test {
namespace {

// As the simulator draws yarn: the section stops where it steepens past
// this slope (fibres fill the crease beyond), and a light blur rounds the
// kinks where sections meet.
constexpr double kCreaseSlope = 1.5;
constexpr double kSmoothingMm = 0.02;
constexpr float kGapShade = 0.8f;
constexpr float kFlankShade = 0.15f;

// Each curve's arc length at each point, to find the point a pixel shows.
std::vector<std::vector<float>> arc_lengths(const cloth::YarnSet& yarns) {
  std::vector<std::vector<float>> arcs;
  for (const cloth::YarnCurve& curve : yarns.curves) {
    std::vector<float> arc(curve.points.size(), 0.0f);
    for (std::size_t i = 1; i < arc.size(); ++i)
      arc[i] = arc[i - 1] + (curve.points[i] - curve.points[i - 1]).norm();
    arcs.push_back(std::move(arc));
  }
  return arcs;
}

}  // namespace

KnittedMaps knit_maps(const cloth::StitchChart& chart, cv::Size size, double pixel_size_mm,
                      cloth::ClothDeformation deformation, double noise_mm) {
  const double px = pixel_size_mm;
  cloth::KnitParameters parameters;
  auto probe = cloth::KnitFabric::build(chart, chart.columns, chart.rows, parameters);
  const double face_w = probe->repeat().width_mm / chart.columns;
  const double face_h = probe->repeat().height_mm / chart.rows;
  // Enough stitches for the image, its lean and a margin, whole repeats.
  const double lean = std::abs(deformation.shear) * size.height * px;
  const auto whole = [](double stitches, int repeat) {
    return (static_cast<int>(std::ceil(stitches)) / repeat + 2) * repeat;
  };
  const int columns =
      whole((size.width * px + lean) / (face_w * std::min(1.0f, deformation.stretch)) + 4,
            chart.columns);
  const int rows = whole(size.height * px / face_h + 4, chart.rows);
  auto fabric = cloth::KnitFabric::build(chart, columns, rows, parameters);
  const cloth::StitchMesh mesh = fabric->mesh(deformation);
  cloth::YarnSet yarns;
  fabric->update(mesh, yarns);

  // The image centred on the mesh.
  const Eigen::Vector2d centre =
      0.5 * (mesh.vertex(0, 0) + mesh.vertex(columns, rows)).head<2>().cast<double>();
  const Eigen::Vector2d low = centre - 0.5 * px * Eigen::Vector2d(size.width, size.height);
  const std::vector<cloth::RasterYarn> raster = cloth::raster_yarns(yarns, low, size, px);
  double floor_mm = 0;
  for (const cloth::RasterYarn& yarn : raster)
    for (const cloth::RasterVertex& v : yarn.path)
      floor_mm = std::min(floor_mm, v.z);
  const cloth::YarnRaster view =
      cloth::rasterize_yarns(raster, size, px, static_cast<float>(floor_mm), kCreaseSlope);

  KnittedMaps maps;
  maps.pixel_size_mm = px;
  cv::GaussianBlur(view.top, maps.height, cv::Size(0, 0), kSmoothingMm / px);
  if (noise_mm > 0) {
    cv::Mat noise(size, CV_32F);
    cv::RNG(7).fill(noise, cv::RNG::NORMAL, 0.0, noise_mm);
    maps.height += noise;
  }
  const auto arcs = arc_lengths(yarns);
  maps.albedo.create(size, CV_32FC3);
  for (int r = 0; r < size.height; ++r)
    for (int c = 0; c < size.width; ++c) {
      const int yarn = view.yarn.at<int>(r, c);
      Eigen::Vector3f colour = yarns.style.colour;
      if (yarn >= 0 && !yarns.curves[static_cast<std::size_t>(yarn)].colours.empty()) {
        const auto& arc = arcs[static_cast<std::size_t>(yarn)];
        const auto point = static_cast<std::size_t>(
            std::lower_bound(arc.begin(), arc.end(), view.along.at<float>(r, c)) - arc.begin());
        const auto& colours = yarns.curves[static_cast<std::size_t>(yarn)].colours;
        colour = colours[std::min(point, colours.size() - 1)];
      }
      // A yarn's flanks and the gaps between yarns look darker (fibres
      // shade one another), as the simulator's and a real scan's albedo do.
      const float across = view.across.at<float>(r, c);
      const float shade = yarn < 0 ? kGapShade : 1 - kFlankShade * across * across;
      maps.albedo.at<cv::Vec3f>(r, c) = cv::Vec3f(colour.z(), colour.y(), colour.x()) * shade;
    }
  // Wale lines lean with the shear: their spacing across is the stretched
  // wale over sqrt(1 + shear^2); the course lines stay a course apart.
  maps.wales_per_cm = 10 * std::hypot(1.0, deformation.shear) / (deformation.stretch * face_w);
  maps.courses_per_cm = 10 / face_h;
  return maps;
}

}  // namespace psrig::test
