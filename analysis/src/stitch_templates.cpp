#include "psrig/analysis/stitch_templates.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "psrig/cloth/knit_fabric.h"
#include "psrig/cloth/yarn_raster.h"

namespace psrig::analysis {
namespace {

// The middle repeat of the field knitted sees at least this many stitches
// across and up round it (the whole field).
constexpr int kMinFieldStitches = 5;
// The slope past which a yarn's section is not drawn: what lies beyond is
// the crease under it, which fibres fill on real cloth (as the simulator does).
constexpr double kCreaseSlope = 1.5;
// A draft's yarn points between key points and relaxation sweeps.
constexpr int kDraftSamplesPerSpan = 2;
constexpr int kDraftIterations = 60;
constexpr int kDraftMaxIterations = 200;

cloth::StitchChart single(cloth::Stitch stitch) {
  cloth::StitchChart chart;
  chart.name = stitch == cloth::Stitch::knit ? "knit" : "purl";
  chart.columns = 1;
  chart.rows = 1;
  chart.cells = {stitch};
  chart.colour_index = {0};
  return chart;
}

// Bilinear look-up at a point of the cloth's plane; the raster's row 0 is
// at the top of the region it covers.
float height_at(const cv::Mat& top, Eigen::Vector2d origin_mm, double px, Eigen::Vector3f point) {
  const double x = (point.x() - origin_mm.x()) / px - 0.5;
  const double y = (origin_mm.y() + top.rows * px - point.y()) / px - 0.5;
  const int x0 = std::clamp(static_cast<int>(std::floor(x)), 0, top.cols - 2);
  const int y0 = std::clamp(static_cast<int>(std::floor(y)), 0, top.rows - 2);
  const auto fx = static_cast<float>(std::clamp(x - x0, 0.0, 1.0));
  const auto fy = static_cast<float>(std::clamp(y - y0, 0.0, 1.0));
  const float a = top.at<float>(y0, x0) * (1 - fx) + top.at<float>(y0, x0 + 1) * fx;
  const float b = top.at<float>(y0 + 1, x0) * (1 - fx) + top.at<float>(y0 + 1, x0 + 1) * fx;
  return a * (1 - fy) + b * fy;
}

bool normalise(cv::Mat& face) {
  face -= cv::mean(face)[0];
  const double norm = cv::norm(face);
  if (!(norm > 0)) return false;
  face /= norm;
  return true;
}

}  // namespace

Result<cv::Mat> render_chart_repeat(const cloth::StitchChart& pattern, float wale_mm,
                                    float course_mm, float yarn_mm, int samples, bool draft) {
  if (!(wale_mm > 0) || !(course_mm > 0) || samples < 4 || pattern.cells.empty())
    return std::unexpected(bad_input({}, {}, "a rendered repeat needs a chart, a positive wale and "
                                             "course spacing and at least 4 samples a side"));
  cloth::StitchChart chart = pattern;
  chart.gauge = {};
  chart.palette.clear();
  cloth::KnitParameters parameters;
  parameters.gauge = {10 / wale_mm, 10 / course_mm, yarn_mm};
  if (draft) {
    parameters.samples_per_span = kDraftSamplesPerSpan;
    parameters.relax.iterations = kDraftIterations;
    parameters.relax.max_iterations = kDraftMaxIterations;
  }
  // Repeats round the middle one, enough that it has whole stitches of
  // neighbours on every side.
  const auto field = [](int stitches) {
    const int repeats = std::max(3, (kMinFieldStitches + stitches - 1) / stitches);
    return repeats | 1;  // odd: one in the middle
  };
  const int across = field(chart.columns), up = field(chart.rows);
  const int first_column = across / 2 * chart.columns, first_row = up / 2 * chart.rows;
  auto fabric =
      cloth::KnitFabric::build(chart, across * chart.columns, up * chart.rows, parameters);
  if (!fabric) return std::unexpected(fabric.error());
  const cloth::StitchMesh mesh = fabric->mesh();
  cloth::YarnSet yarns;
  fabric->update(mesh, yarns);

  // The middle repeat rasterised, finely enough that the samples
  // interpolate between pixels.
  const double px = std::min(wale_mm, course_mm) / (2.0 * samples);
  const Eigen::Vector2d low =
      mesh.vertex(first_column, first_row).head<2>().cast<double>() - Eigen::Vector2d(px, px);
  const Eigen::Vector2d high =
      mesh.vertex(first_column + chart.columns, first_row + chart.rows).head<2>().cast<double>();
  const cv::Size size(static_cast<int>(std::ceil((high.x() - low.x()) / px)) + 2,
                      static_cast<int>(std::ceil((high.y() - low.y()) / px)) + 2);
  const std::vector<cloth::RasterYarn> raster = cloth::raster_yarns(yarns, low, size, px);
  double floor_mm = 0;
  for (const cloth::RasterYarn& yarn : raster)
    for (const cloth::RasterVertex& v : yarn.path)
      floor_mm = std::min(floor_mm, v.z);
  const cloth::YarnRaster view =
      cloth::rasterize_yarns(raster, size, px, static_cast<float>(floor_mm), kCreaseSlope);

  const int n = samples;
  cv::Mat repeat(chart.rows * n, chart.columns * n, CV_32F);
  for (int row = 0; row < chart.rows; ++row)
    for (int column = 0; column < chart.columns; ++column)
      for (int r = 0; r < n; ++r)
        for (int c = 0; c < n; ++c) {
          const float u = (static_cast<float>(c) + 0.5f) / static_cast<float>(n);
          const float v = 1 - (static_cast<float>(r) + 0.5f) / static_cast<float>(n);
          const Eigen::Vector3f point =
              mesh.point(first_column + column, first_row + row, u, v);
          repeat.at<float>((chart.rows - 1 - row) * n + r, column * n + c) =
              height_at(view.top, low, px, point);
        }
  return repeat;
}

Result<StitchTemplates> render_stitch_templates(float wale_mm, float course_mm, int samples) {
  StitchTemplates templates;
  templates.samples = samples;
  for (const cloth::Stitch stitch : {cloth::Stitch::knit, cloth::Stitch::purl}) {
    auto face = render_chart_repeat(single(stitch), wale_mm, course_mm, 0, samples);
    if (!face) return std::unexpected(face.error());
    if (!normalise(*face))
      return std::unexpected(internal_error("a rendered stitch face came out flat"));
    (stitch == cloth::Stitch::knit ? templates.knit : templates.purl) = std::move(*face);
  }
  return templates;
}

}  // namespace psrig::analysis
