// psrig integrate: a height map from normal or gradient maps made anywhere.

#include <cstdio>
#include <filesystem>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <unistd.h>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "command.h"
#include "psrig/base/parallel.h"
#include "psrig/formats/image_io.h"
#include "psrig/formats/map_encoding.h"
#include "psrig/processing/flatten.h"
#include "psrig/processing/integration.h"

namespace psrig::cli {
namespace {

namespace fs = std::filesystem;

struct IntegrateArgs {
  std::vector<std::string> inputs;  // NORMAL, or P Q
  std::string mask;
  std::string out;
  std::string method = "auto";
  std::string flatten = "auto";
  double flatten_cutoff = processing::kDefaultFlattenCutoffMm;
  double pixel_size = 0;  // 0: unknown, heights in pixels
  bool green_down = false;
  int threads = 0;
  bool quiet = false;
};

bool has_float_extension(const fs::path& file) {
  const std::string ext = file.extension().string();
  return ext == ".exr" || ext == ".tif" || ext == ".tiff";
}

// p and q from the inputs: one normal map, or two one-channel float maps.
Result<formats::DecodedGradients> read_gradients(const IntegrateArgs& args) {
  if (args.inputs.size() == 1) {
    const fs::path file = args.inputs[0];
    auto image = formats::read_image(file, "NORMAL");
    if (!image) return std::unexpected(image.error());
    auto decoded = formats::decode_normal_map(*image, args.green_down);
    if (decoded.p.empty())
      return std::unexpected(
          bad_input(file, "NORMAL",
                    "not a normal map: expected 3 or 4 channels of 8-bit, 16-bit or float (got " +
                        std::to_string(image->channels()) + " channel(s), " +
                        cv::typeToString(image->type()) + "); for gradient maps give P and Q"));
    return decoded;
  }
  formats::DecodedGradients g;
  for (std::size_t i = 0; i < 2; ++i) {
    const fs::path file = args.inputs[i];
    const char* key = i == 0 ? "P" : "Q";
    auto image = formats::read_image(file, key);
    if (!image) return std::unexpected(image.error());
    if (image->type() != CV_32FC1)
      return std::unexpected(
          bad_input(file, key,
                    "expected a one-channel 32-bit float gradient map (EXR or TIFF), got " +
                        cv::typeToString(image->type()) + "; for a normal map give it alone"));
    (i == 0 ? g.p : g.q) = *image;
  }
  if (g.p.size() != g.q.size())
    return std::unexpected(bad_input(
        args.inputs[1], "Q",
        "is " + std::to_string(g.q.cols) + "x" + std::to_string(g.q.rows) + " but P is " +
            std::to_string(g.p.cols) + "x" + std::to_string(g.p.rows) + "; give maps of one size"));
  return g;
}

Result<cv::Mat> read_mask(const std::string& name, cv::Size size) {
  if (name.empty()) return cv::Mat();
  auto image = formats::read_image(name, "--mask");
  if (!image) return std::unexpected(image.error());
  if (image->channels() != 1 || (image->depth() != CV_8U && image->depth() != CV_16U))
    return std::unexpected(bad_input(name, "--mask",
                                     "expected an 8- or 16-bit grey image (nonzero = integrate "
                                     "this pixel), got " +
                                         cv::typeToString(image->type())));
  if (image->size() != size)
    return std::unexpected(
        bad_input(name, "--mask",
                  "is " + std::to_string(image->cols) + "x" + std::to_string(image->rows) +
                      " but the maps are " + std::to_string(size.width) + "x" +
                      std::to_string(size.height) + "; give a mask of the maps' size"));
  cv::Mat mask = *image != 0;
  return mask;
}

// Writes beside the target, then renames: the file appears whole or not at
// all, and an earlier one stays until then.
Status write_atomically(const fs::path& target, const cv::Mat& height) {
  const fs::path parent = target.has_parent_path() ? target.parent_path() : fs::path(".");
  const fs::path staging = parent / ("." + target.stem().string() + ".partial-" +
                                     std::to_string(::getpid()) + target.extension().string());
  if (auto ok = formats::write_image(staging, height); !ok) {
    std::error_code ignored;
    fs::remove(staging, ignored);
    return ok;
  }
  std::error_code ec;
  fs::rename(staging, target, ec);
  if (ec) {
    std::error_code ignored;
    fs::remove(staging, ignored);
    return std::unexpected(io_error(target, "cannot rename into place: " + ec.message()));
  }
  return {};
}

int run_integrate(const IntegrateArgs& args) {
  psrig::set_thread_count(args.threads);
  const fs::path out = args.out;
  if (!has_float_extension(out))
    return report_error(
        "integrate",
        bad_input(out, "--out", "the height map is float: name a .exr, .tif or .tiff file"));
  std::error_code ec;
  if (fs::is_directory(out, ec))
    return report_error("integrate",
                        bad_input(out, "--out", "is a directory; name the height file"));
  const fs::path parent = out.has_parent_path() ? out.parent_path() : fs::path(".");
  if (!fs::is_directory(parent, ec))
    return report_error("integrate",
                        bad_input(out, "--out", "its directory does not exist; make it first"));

  auto gradients = read_gradients(args);
  if (!gradients) return report_error("integrate", gradients.error());
  auto mask = read_mask(args.mask, gradients->p.size());
  if (!mask) return report_error("integrate", mask.error());

  auto method = *processing::parse_integration_method(args.method);
  if (method == processing::IntegrationMethod::automatic)
    method = processing::needs_masked_integration(gradients->p, gradients->q, *mask)
                 ? processing::IntegrationMethod::masked
                 : processing::IntegrationMethod::frankot_chellappa;
  processing::MaskedIntegrationStats stats;
  Result<cv::Mat> height = cv::Mat();
  if (method == processing::IntegrationMethod::masked) {
    height = processing::integrate_masked(gradients->p, gradients->q, *mask, {}, &stats);
  } else {
    // The whole rectangle: gradients outside the mask count as 0, and their
    // heights are left out of the file as the masked solver's are.
    if (!mask->empty()) {
      gradients->p.setTo(0.0F, *mask == 0);
      gradients->q.setTo(0.0F, *mask == 0);
    }
    height = processing::integrate(method, gradients->p, gradients->q);
    if (height && !mask->empty())
      height->setTo(std::numeric_limits<float>::quiet_NaN(), *mask == 0);
  }
  if (!height) return report_error("integrate", height.error());

  const bool in_mm = args.pixel_size > 0;
  if (in_mm) *height *= args.pixel_size;
  const bool flatten = args.flatten == "on" || (args.flatten == "auto" && in_mm);
  std::optional<processing::BendRemoved> bend;
  if (flatten) {
    const double cutoff_px = in_mm ? args.flatten_cutoff / args.pixel_size : args.flatten_cutoff;
    auto removed = processing::remove_bend(*height, cutoff_px);
    if (!removed) return report_error("integrate", removed.error());
    bend = std::move(*removed);
  }
  if (auto ok = write_atomically(out, *height); !ok) return report_error("integrate", ok.error());

  if (!args.quiet) {
    const cv::Mat finite = *height == *height;
    double low = 0;
    double high = 0;
    const int pixels = cv::countNonZero(finite);
    if (pixels > 0) cv::minMaxLoc(*height, &low, &high, nullptr, nullptr, finite);
    const char* units = in_mm ? "mm" : "px";
    std::printf("height: %s\n", out.string().c_str());
    std::printf("method: %s", std::string(processing::to_string(method)).c_str());
    if (method == processing::IntegrationMethod::masked)
      std::printf(" (%d iterations, residual %.2g)", stats.iterations, stats.relative_residual);
    std::printf("\npixels: %d of %d (the rest NaN)\n", pixels, height->rows * height->cols);
    std::printf("range: %.4f %s\n", high - low, units);
    if (bend)
      std::printf("bend removed: %.4f %s peak to valley (cut-off %g %s)\n", bend->peak_to_valley,
                  units, args.flatten_cutoff, units);
  }
  return 0;
}

}  // namespace

Command add_integrate_command(CLI::App& parent) {
  auto args = std::make_shared<IntegrateArgs>();
  CLI::App* app = parent.add_subcommand(
      "integrate", "Integrate a normal map, or p and q gradient maps, into a height map");
  app->add_option("maps", args->inputs,
                  "NORMAL (RGB PNG 8/16-bit as (n+1)/2, or float EXR/TIFF as n), or P Q "
                  "(one-channel float EXR/TIFF, p = dz/dx, q = dz/dy, y up)")
      ->required()
      ->expected(1, 2);
  app->add_option("--out", args->out, "Height map to write (.exr, .tif or .tiff), float32")
      ->required();
  app->add_option("--mask", args->mask, "Grey image, nonzero = integrate this pixel");
  app->add_option("--method", args->method,
                  "auto (masked where a mask or missing normals leave pixels out, else fc), "
                  "masked, fc or poisson")
      ->check(CLI::IsMember({"auto", "masked", "fc", "poisson"}))
      ->capture_default_str();
  app->add_option("--pixel-size", args->pixel_size,
                  "Millimetres per pixel: heights in mm (default: pixels)")
      ->check(CLI::PositiveNumber);
  app->add_option("--flatten", args->flatten,
                  "Remove the low-frequency bend: auto (when --pixel-size is given), on or off")
      ->check(CLI::IsMember({"auto", "on", "off"}))
      ->capture_default_str();
  app->add_option("--flatten-cutoff", args->flatten_cutoff,
                  "The bend's cut-off wavelength, mm (pixels without --pixel-size)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app->add_flag("--green-down", args->green_down,
                "The normal map is in the DirectX convention (green down)");
  app->add_option("--threads", args->threads, "Worker threads (0: one per core)")
      ->check(psrig::cli::thread_count())
      ->capture_default_str();
  app->add_flag("-q,--quiet", args->quiet, "Print nothing on success");
  return {app, [args] { return run_integrate(*args); }};
}

}  // namespace psrig::cli
