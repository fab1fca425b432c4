// psrig import DIR (--calibration FILE | --directions FILE) --out SCAN_DIR:
// a folder of images, one per light (and an optional mask), as datasets
// ship them, to a psrig-scan/1 directory that `psrig process` takes.

#include <cstdio>
#include <fstream>
#include <memory>
#include <sstream>

#include <opencv2/imgproc.hpp>

#include "command.h"
#include "psrig/calibration/calibration_store.h"
#include "psrig/calibration/image_set.h"
#include "psrig/formats/image_io.h"
#include "psrig/formats/scan_layout.h"
#include "psrig/formats/scan_writer.h"

namespace psrig::cli {
namespace {

namespace fs = std::filesystem;

struct ImportArgs {
  std::string folder;
  std::string calibration;
  std::string directions;
  std::string mask;
  std::string out;
  std::string encoding = "linear";
  std::string sample_id;
  bool quiet = false;
};

// A directions file: one light a line, "x y z" (commas allowed); blank
// lines, '#' comments and a first line holding only the count are skipped.
Result<std::vector<calibration::CalibratedLight>> read_directions(const fs::path& file) {
  std::ifstream in(file);
  if (!in)
    return std::unexpected(bad_input(file, "--directions",
                                     "cannot be read; give a text file with one \"x y z\" line "
                                     "per light"));
  std::vector<calibration::CalibratedLight> lights;
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (const auto hash = line.find('#'); hash != std::string::npos) line.erase(hash);
    for (char& c : line)
      if (c == ',') c = ' ';
    std::istringstream fields(line);
    std::vector<double> values;
    double v = 0;
    while (fields >> v)
      values.push_back(v);
    if (!fields.eof()) {
      Error error = bad_input(file, "", "is not a number list; each line is \"x y z\"");
      error.line = number;
      return std::unexpected(error);
    }
    if (values.empty() || (values.size() == 1 && lights.empty())) continue;
    if (values.size() != 3) {
      Error error = bad_input(
          file, "",
          "has " + std::to_string(values.size()) + " numbers; each line is one light's \"x y z\"");
      error.line = number;
      return std::unexpected(error);
    }
    calibration::CalibratedLight light;
    light.direction = {values[0], values[1], values[2]};
    if (!(cv::norm(light.direction) > 0) || light.direction[2] <= 0) {
      Error error = bad_input(file, "",
                              "gives a direction that does not point toward the camera "
                              "(z must be above 0, axes x right, y up, z to camera)");
      error.line = number;
      return std::unexpected(error);
    }
    light.direction /= cv::norm(light.direction);
    lights.push_back(light);
  }
  if (lights.empty())
    return std::unexpected(
        bad_input(file, "--directions", "holds no directions; one \"x y z\" line per light"));
  return lights;
}

int run_import(const ImportArgs& args) {
  const fs::path folder = args.folder;
  auto images = calibration::list_image_folder(folder);
  if (!images) return report_error("import", images.error());
  std::vector<calibration::CalibratedLight> lights;
  fs::path light_source;
  if (!args.calibration.empty()) {
    auto stored = calibration::read_calibration(args.calibration);
    if (!stored) return report_error("import", stored.error());
    lights = stored->lights;
    light_source = args.calibration;
  } else {
    auto read = read_directions(args.directions);
    if (!read) return report_error("import", read.error());
    lights = *read;
    light_source = args.directions;
  }
  if (images->images.size() != lights.size())
    return report_error(
        "import", bad_input(folder, "",
                            "holds " + std::to_string(images->images.size()) + " images but " +
                                light_source.string() + " gives " + std::to_string(lights.size()) +
                                " lights; give one image per light (in name order, 2 before "
                                "10) or the matching calibration"));
  if (lights.size() < 3)
    return report_error("import", bad_input(light_source, "",
                                            "gives " + std::to_string(lights.size()) +
                                                " lights; a scan has 3 or more"));

  formats::Scan scan;
  auto& d = scan.description;
  d.encoding = args.encoding == "srgb" ? formats::Encoding::srgb : formats::Encoding::linear;
  d.sample_id = args.sample_id.empty() ? fs::absolute(folder).lexically_normal().filename().string()
                                       : args.sample_id;
  if (d.sample_id.empty()) d.sample_id = fs::absolute(folder).parent_path().filename().string();
  d.sample_description = "imported from " + fs::absolute(folder).lexically_normal().string();
  nlohmann::json files = nlohmann::json::array();
  for (std::size_t k = 0; k < images->images.size(); ++k) {
    const fs::path& file = images->images[k];
    auto image = formats::read_image(file, "");
    if (!image) return report_error("import", image.error());
    if (image->depth() != CV_8U && image->depth() != CV_16U && image->depth() != CV_32F)
      return report_error("import", bad_input(file, "",
                                              "has an unsupported pixel type; give 8- or 16-bit "
                                              "PNG or 32-bit float TIFF/EXR images"));
    if (image->channels() == 4) cv::cvtColor(*image, *image, cv::COLOR_BGRA2BGR);
    if (image->channels() != 1 && image->channels() != 3)
      return report_error("import", bad_input(file, "",
                                              "has " + std::to_string(image->channels()) +
                                                  " channels; give grey or RGB images"));
    if (k > 0) {
      const cv::Mat& first = scan.frames.front();
      if (image->size() != first.size() || image->type() != first.type())
        return report_error(
            "import",
            bad_input(file, "",
                      "differs from " + images->images.front().filename().string() +
                          " in size, channels or bit depth; every image of a scan shares them"));
    }
    scan.frames.push_back(*image);
    formats::ScanLight light;
    light.direction = lights[k].direction;
    light.intensity_bgr = cv::Vec3d::all(lights[k].intensity);
    d.lights.push_back(light);
    files.push_back(file.filename().string());
  }
  const fs::path mask_file = !args.mask.empty() ? fs::path(args.mask)
                             : images->mask     ? *images->mask
                                                : fs::path();
  if (!mask_file.empty()) {
    auto mask = calibration::read_mask(mask_file, "--mask");
    if (!mask) return report_error("import", mask.error());
    if (mask->size() != scan.frames.front().size())
      return report_error(
          "import",
          bad_input(mask_file, "--mask",
                    "is " + std::to_string(mask->cols) + "x" + std::to_string(mask->rows) +
                        " but the images are " + std::to_string(scan.frames.front().cols) + "x" +
                        std::to_string(scan.frames.front().rows)));
    scan.mask = *mask;
    d.mask = formats::scan_files::kMask;
  }
  scan.white_level = formats::full_scale(scan.frames.front().depth());
  d.document = nlohmann::json::object();
  d.document["capture"] = {
      {"imported_from", fs::absolute(folder).lexically_normal().string()},
      {"files", files},
      {"mask", mask_file.empty() ? nlohmann::json(nullptr)
                                 : nlohmann::json(mask_file.filename().string())}};
  d.document["calibration"] = {
      {"file", fs::absolute(light_source).lexically_normal().string()},
      {"kind", args.calibration.empty() ? "directions" : "psrig-calibration/1"}};

  std::error_code ec;
  const fs::path out = args.out;
  if (!out.parent_path().empty()) fs::create_directories(out.parent_path(), ec);
  if (auto written = formats::write_scan(scan, out); !written)
    return report_error("import", written.error());
  if (!args.quiet)
    std::printf("%s: %zu lights%s, from %s\n", out.c_str(), lights.size(),
                mask_file.empty() ? "" : ", masked", folder.c_str());
  return 0;
}

}  // namespace

Command add_import_command(CLI::App& parent) {
  auto args = std::make_shared<ImportArgs>();
  CLI::App* app = parent.add_subcommand(
      "import", "Make a scan directory from a folder of images, one per light, and their lights");
  app->add_option("folder", args->folder,
                  "Folder of images, one per light in name order (a file whose name ends in "
                  "\"mask\" is the mask)")
      ->required();
  auto* calibration = app->add_option("--calibration", args->calibration,
                                      "A calibration.json (psrig calibrate lights) for the lights");
  auto* directions = app->add_option("--directions", args->directions,
                                     "A text file, one \"x y z\" light direction a line");
  calibration->excludes(directions);
  app->add_option("--mask", args->mask,
                  "Mask image (grey, or RGB with R=G=B; nonzero = use); default: the folder's");
  app->add_option("--out", args->out, "Scan directory to create (must not exist)")->required();
  app->add_option("--encoding", args->encoding, "How the images store light: linear or srgb")
      ->check(CLI::IsMember({"linear", "srgb"}))
      ->capture_default_str();
  app->add_option("--sample-id", args->sample_id,
                  "The sample's label (default: the folder's name)");
  app->add_flag("-q,--quiet", args->quiet, "Print nothing on success");
  return {app, [args] {
            if (args->calibration.empty() && args->directions.empty()) {
              std::fprintf(stderr,
                           "psrig import: error: give the lights: --calibration FILE (from psrig "
                           "calibrate lights) or --directions FILE\n");
              return 2;
            }
            return run_import(*args);
          }};
}

}  // namespace psrig::cli
