#include "psrig/formats/scan_reader.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <mutex>
#include <sstream>

#include "frame_bands_state.h"
#include "png_codec.h"
#include "psrig/base/parallel.h"
#include "psrig/formats/image_io.h"
#include "psrig/formats/light_matrix.h"
#include "psrig/formats/scan_layout.h"
#include "psrig/formats/scan_writer.h"

namespace psrig::formats {
namespace {

using nlohmann::json;
namespace fs = std::filesystem;

// Checks one scan.json in the context of its file, so every error names both.
class DescriptionParser {
 public:
  explicit DescriptionParser(fs::path file) : file_(std::move(file)) {}

  [[nodiscard]] Error error(const std::string& key, const std::string& message) const {
    return bad_input(file_, key, message);
  }

  // A file name that stays inside the scan directory.
  Result<std::string> file_name(const json& value, const std::string& key) const {
    if (!value.is_string() || value.get<std::string>().empty())
      return std::unexpected(error(key, "expected a file name (a non-empty string)"));
    const auto name = value.get<std::string>();
    const fs::path path(name);
    if (path.is_absolute())
      return std::unexpected(
          error(key, "'" + name + "' is absolute; name a file inside the scan directory"));
    for (const auto& part : path)
      if (part == "..")
        return std::unexpected(
            error(key, "'" + name + "' leaves the scan directory; name a file inside it"));
    return name;
  }

  Result<std::optional<std::string>> optional_file_name(const json& object,
                                                        const std::string& key) const {
    if (!object.contains(key) || object.at(key).is_null()) return std::optional<std::string>{};
    auto name = file_name(object.at(key), key);
    if (!name) return std::unexpected(name.error());
    return std::optional<std::string>{*name};
  }

  Result<double> finite_number(const json& value, const std::string& key) const {
    if (!value.is_number()) return std::unexpected(error(key, "expected a number"));
    const double number = value.get<double>();
    if (!std::isfinite(number)) return std::unexpected(error(key, "must be finite"));
    return number;
  }

  Result<cv::Vec3d> direction(const json& value, const std::string& key) const {
    if (!value.is_array() || value.size() != 3)
      return std::unexpected(error(key, "expected [x, y, z], three numbers"));
    cv::Vec3d d;
    for (int i = 0; i < 3; ++i) {
      if (!value[i].is_number())
        return std::unexpected(error(key, "expected [x, y, z], three numbers"));
      d[i] = value[i].get<double>();  // finite: JSON cannot carry NaN or infinity
    }
    if (cv::norm(d) < 1e-9)
      return std::unexpected(error(key, "is the zero vector; give the direction toward the light"));
    return d / cv::norm(d);
  }

  Status intensity(const json& value, const std::string& key, ScanLight& light) const {
    if (value.is_number()) {
      auto scalar = finite_number(value, key);
      if (!scalar) return std::unexpected(scalar.error());
      if (*scalar <= 0) return std::unexpected(error(key, "must be positive"));
      light.intensity_bgr = {*scalar, *scalar, *scalar};
      return {};
    }
    if (value.is_array() && value.size() == 3) {
      cv::Vec3d rgb;
      for (int i = 0; i < 3; ++i) {
        auto component = finite_number(value[i], key);
        if (!component) return std::unexpected(component.error());
        if (*component <= 0) return std::unexpected(error(key, "components must be positive"));
        rgb[i] = *component;
      }
      light.intensity_bgr = {rgb[2], rgb[1], rgb[0]};
      light.intensity_is_rgb = true;
      return {};
    }
    return std::unexpected(error(key, "expected a positive number or [r, g, b]"));
  }

  Result<ScanDescription> parse(const json& doc, const fs::path& directory) const {
    if (!doc.is_object())
      return std::unexpected(error("", "expected a JSON object at the top level"));
    ScanDescription d;
    d.directory = directory;
    d.document = doc;

    if (!doc.contains("format"))
      return std::unexpected(error("format", "missing; expected \"psrig-scan/1\""));
    if (!doc["format"].is_string() || doc["format"].get<std::string>() != kScanFormat)
      return std::unexpected(
          error("format", "is " + doc["format"].dump() + "; this psrig reads \"psrig-scan/1\""));

    if (doc.contains("sample") && !doc["sample"].is_null()) {
      const auto& sample = doc["sample"];
      if (!sample.is_object())
        return std::unexpected(error("sample", "expected an object {id, description}"));
      if (sample.contains("id")) {
        if (!sample["id"].is_string())
          return std::unexpected(error("sample.id", "expected a string"));
        d.sample_id = sample["id"].get<std::string>();
      }
      if (sample.contains("description")) {
        if (!sample["description"].is_string())
          return std::unexpected(error("sample.description", "expected a string"));
        d.sample_description = sample["description"].get<std::string>();
      }
    }

    if (doc.contains("encoding") && !doc["encoding"].is_null()) {
      const auto& e = doc["encoding"];
      if (e == "linear")
        d.encoding = Encoding::linear;
      else if (e == "srgb")
        d.encoding = Encoding::srgb;
      else
        return std::unexpected(
            error("encoding", "is " + e.dump() + "; expected \"linear\" or \"srgb\""));
    }

    if (doc.contains("black_level") && !doc["black_level"].is_null()) {
      auto black = finite_number(doc["black_level"], "black_level");
      if (!black) return std::unexpected(black.error());
      if (*black < 0) return std::unexpected(error("black_level", "must not be negative"));
      d.black_level = *black;
    }
    if (doc.contains("white_level") && !doc["white_level"].is_null()) {
      auto white = finite_number(doc["white_level"], "white_level");
      if (!white) return std::unexpected(white.error());
      if (*white <= d.black_level)
        return std::unexpected(error(
            "white_level", "must be above black_level (" + std::to_string(d.black_level) + ")"));
      d.white_level = *white;
    }

    for (const char* key : {"dark", "mask"}) {
      auto name = optional_file_name(doc, key);
      if (!name) return std::unexpected(name.error());
      (std::string(key) == "dark" ? d.dark : d.mask) = *name;
    }

    if (!doc.contains("lights"))
      return std::unexpected(error("lights", "missing; list at least three lights"));
    const auto& lights = doc["lights"];
    if (!lights.is_array()) return std::unexpected(error("lights", "expected an array of lights"));
    if (lights.size() < 3)
      return std::unexpected(
          error("lights", std::to_string(lights.size()) +
                              " light(s) given; photometric stereo needs at least three"));
    for (std::size_t i = 0; i < lights.size(); ++i) {
      const std::string prefix = "lights[" + std::to_string(i) + "]";
      const auto& entry = lights[i];
      if (!entry.is_object())
        return std::unexpected(error(prefix, "expected an object {image, direction, intensity}"));
      ScanLight light;
      if (!entry.contains("image")) return std::unexpected(error(prefix + ".image", "missing"));
      auto image = file_name(entry["image"], prefix + ".image");
      if (!image) return std::unexpected(image.error());
      light.image = *image;
      if (!entry.contains("direction"))
        return std::unexpected(error(prefix + ".direction", "missing"));
      auto dir = direction(entry["direction"], prefix + ".direction");
      if (!dir) return std::unexpected(dir.error());
      light.direction = *dir;
      if (light.direction[2] <= 0)
        return std::unexpected(error(prefix + ".direction",
                                     "points below the swatch (z <= 0); z is toward the camera"));
      if (entry.contains("intensity") && !entry["intensity"].is_null()) {
        if (auto ok = intensity(entry["intensity"], prefix + ".intensity", light); !ok)
          return std::unexpected(ok.error());
      }
      const bool has_position = entry.contains("position_mm") && !entry["position_mm"].is_null();
      if (has_position) {
        const auto& value = entry["position_mm"];
        const std::string key = prefix + ".position_mm";
        if (!value.is_array() || value.size() != 3)
          return std::unexpected(error(key, "expected [x, y, z] in millimetres"));
        cv::Vec3d position;
        for (int k = 0; k < 3; ++k) {
          if (!value[k].is_number())
            return std::unexpected(error(key, "expected [x, y, z] in millimetres"));
          position[k] = value[k].get<double>();
        }
        if (position[2] <= 0)
          return std::unexpected(
              error(key, "is at or below the swatch plane (z <= 0); z is toward the camera"));
        light.position_mm = position;
      }
      if (i > 0 && has_position != d.lights.front().position_mm.has_value())
        return std::unexpected(error(
            prefix + ".position_mm",
            has_position ? "given, but lights[0] has none: give every light a position or none"
                         : "missing, but lights[0] has one: give every light a position or none"));
      d.lights.push_back(light);
    }

    if (!doc.contains("flats") || doc["flats"].is_null()) {
      // No key: the layout names them flat0.png, flat1.png, ...
      for (const auto extension : scan_files::kFrameExtensions) {
        if (!std::filesystem::exists(directory / scan_files::flat_frame(0, extension))) continue;
        for (std::size_t i = 0; i < lights.size(); ++i)
          d.flats.push_back(scan_files::flat_frame(static_cast<int>(i), extension));
        break;
      }
    } else {
      const auto& flats = doc["flats"];
      if (!flats.is_array() || flats.size() != lights.size())
        return std::unexpected(error("flats", "expected one flat-field frame per light (" +
                                                  std::to_string(lights.size()) + " file names)"));
      for (std::size_t i = 0; i < flats.size(); ++i) {
        auto name = file_name(flats[i], "flats[" + std::to_string(i) + "]");
        if (!name) return std::unexpected(name.error());
        d.flats.push_back(*name);
      }
    }

    if (doc.contains("pixel_size_mm") && !doc["pixel_size_mm"].is_null()) {
      auto size = finite_number(doc["pixel_size_mm"], "pixel_size_mm");
      if (!size) return std::unexpected(size.error());
      if (*size <= 0)
        return std::unexpected(error("pixel_size_mm", "must be positive (or null when unknown)"));
      d.pixel_size_mm = *size;
    }
    if (d.near_field() && !d.pixel_size_mm)
      return std::unexpected(
          error("lights[0].position_mm", "needs pixel_size_mm to place the pixels on the swatch"));

    if (doc.contains("principal_point_px") && !doc["principal_point_px"].is_null()) {
      const auto& value = doc["principal_point_px"];
      if (!value.is_array() || value.size() != 2 || !value[0].is_number() || !value[1].is_number())
        return std::unexpected(
            error("principal_point_px", "expected [x, y] in pixels (column, row)"));
      d.principal_point_px = cv::Point2d(value[0].get<double>(), value[1].get<double>());
    }

    if (doc.contains("ground_truth") && !doc["ground_truth"].is_null()) {
      const auto& truth = doc["ground_truth"];
      if (!truth.is_object())
        return std::unexpected(error("ground_truth", "expected an object {normal, height}"));
      auto normal = optional_file_name(truth, "normal");
      if (!normal) return std::unexpected(error("ground_truth.normal", normal.error().message));
      auto height = optional_file_name(truth, "height");
      if (!height) return std::unexpected(error("ground_truth.height", height.error().message));
      d.ground_truth_normal = *normal;
      d.ground_truth_height = *height;
    }

    const double condition = make_light_matrix(d).condition_number;
    if (!(condition <= kMaxLightConditionNumber)) {
      std::ostringstream message;
      message << "the light directions are degenerate (light matrix condition number " << condition
              << ", limit " << kMaxLightConditionNumber
              << "): they must not lie in one plane; spread their tilts and give them slant";
      return std::unexpected(error("lights", message.str()));
    }
    return d;
  }

 private:
  fs::path file_;
};

// 1-based line and column of a byte offset (as nlohmann reports it).
std::pair<int, int> line_and_column(const std::string& text, std::size_t byte) {
  int line = 1, column = 1;
  for (std::size_t i = 0; i + 1 < byte && i < text.size(); ++i) {
    if (text[i] == '\n') {
      ++line;
      column = 1;
    } else {
      ++column;
    }
  }
  return {line, column};
}

std::string describe_image(const cv::Mat& image) {
  return std::to_string(image.cols) + "x" + std::to_string(image.rows) + " " +
         depth_name(image.depth()) + " " +
         (image.channels() == 1 ? "grey" : std::to_string(image.channels()) + "-channel");
}

// One image the description names, with where it goes once loaded.
struct ImageRequest {
  std::string name;
  std::string key;
  cv::Mat* destination;
};

}  // namespace

Result<ScanDescription> read_scan_description(const fs::path& directory) {
  std::error_code ec;
  if (!fs::is_directory(directory, ec))
    return std::unexpected(bad_input(
        directory, "", fs::exists(directory, ec) ? "not a directory" : "no such scan directory"));
  const fs::path file = directory / scan_files::kDescription;
  if (!fs::exists(file, ec))
    return std::unexpected(bad_input(file, "", "missing: a scan directory holds scan.json"));
  std::ifstream stream(file, std::ios::binary);
  if (!stream) return std::unexpected(bad_input(file, "", "cannot open for reading"));
  std::stringstream buffer;
  buffer << stream.rdbuf();
  const std::string text = buffer.str();

  nlohmann::json doc;
  try {
    doc = nlohmann::json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    Error error = bad_input(file, "", std::string("malformed JSON: ") + e.what());
    std::tie(error.line, error.column) = line_and_column(text, e.byte);
    return std::unexpected(error);
  } catch (const nlohmann::json::exception& e) {  // e.g. a number too large for a double
    return std::unexpected(bad_input(file, "", std::string("malformed JSON: ") + e.what()));
  }
  return DescriptionParser(file).parse(doc, directory);
}

namespace {

// Every image scan.json names, and where in `scan` it goes; the ground
// truth only `with_truth`.
std::vector<ImageRequest> image_requests(Scan& scan, bool with_truth = true) {
  const auto& d = scan.description;
  std::vector<ImageRequest> requests;
  for (std::size_t i = 0; i < d.lights.size(); ++i)
    requests.push_back(
        {d.lights[i].image, "lights[" + std::to_string(i) + "].image", &scan.frames[i]});
  if (d.dark) requests.push_back({*d.dark, "dark", &scan.dark});
  if (d.mask) requests.push_back({*d.mask, "mask", &scan.mask});
  for (std::size_t i = 0; i < d.flats.size(); ++i)
    requests.push_back({d.flats[i], "flats[" + std::to_string(i) + "]", &scan.flats[i]});
  if (d.ground_truth_normal && with_truth)
    requests.push_back({*d.ground_truth_normal, "ground_truth.normal", &scan.ground_truth_normal});
  if (d.ground_truth_height && with_truth)
    requests.push_back({*d.ground_truth_height, "ground_truth.height", &scan.ground_truth_height});

  return requests;
}

// A ground-truth image: the frames' size, float, three channels for the
// normals and one for the height.
Status check_ground_truth(const ImageRequest& request, const cv::Mat& image, cv::Size frames,
                          const fs::path& directory) {
  const int expected = request.key.ends_with("normal") ? CV_32FC3 : CV_32FC1;
  if (image.size() != frames || image.type() != expected)
    return std::unexpected(
        bad_input(directory / request.name, request.key,
                  "is " + describe_image(image) + "; expected " + std::to_string(frames.width) +
                      "x" + std::to_string(frames.height) +
                      (expected == CV_32FC3 ? " 32-bit float 3-channel" : " 32-bit float grey")));
  return {};
}

// Cross-checks the images against each other and scan.json, and makes the
// mask 0/255 whatever it was stored as.
Status check_images(Scan& scan, const std::vector<ImageRequest>& requests,
                    const fs::path& directory) {
  const auto& d = scan.description;
  // Cross-checks: every frame like the first.
  const cv::Mat& first = scan.frames.front();
  const auto frame_error = [&](const ImageRequest& request, const std::string& what) {
    return bad_input(directory / request.name, request.key, what);
  };
  const auto check_like_first = [&](const ImageRequest& request, const cv::Mat& image) -> Status {
    if (image.size() != first.size() || image.channels() != first.channels() ||
        image.depth() != first.depth())
      return std::unexpected(
          frame_error(request, "is " + describe_image(image) + " but " + d.lights[0].image +
                                   " is " + describe_image(first) +
                                   "; all frames of a scan share size, channels and bit depth"));
    return {};
  };
  for (std::size_t i = 0; i < requests.size(); ++i) {
    const auto& request = requests[i];
    const cv::Mat& image = *request.destination;
    if (request.key == "mask") {
      if (image.size() != first.size())
        return std::unexpected(frame_error(
            request, "is " + describe_image(image) + " but the frames are " +
                         std::to_string(first.cols) + "x" + std::to_string(first.rows)));
      // Grey, or colour whose channels agree: RGB masks with R = G = B and
      // palette PNGs (which OpenCV expands to BGR) as datasets ship them.
      cv::Mat grey = image;
      if (image.channels() != 1) {
        std::vector<cv::Mat> planes;
        cv::split(image, planes);
        const int colours = std::min(3, image.channels());
        for (int c = 1; c < colours; ++c)
          if (cv::countNonZero(planes[c] != planes[0]) > 0)
            return std::unexpected(
                frame_error(request,
                            "is a colour image whose channels differ; a mask is grey, or RGB with "
                            "R = G = B (nonzero = use): save it as a grey PNG"));
        grey = planes[0];
      }
      cv::compare(grey, 0, scan.mask, cv::CMP_NE);  // any nonzero value, of any depth, selects
      continue;
    }
    if (request.key.starts_with("ground_truth")) {
      if (auto ok = check_ground_truth(request, image, first.size(), directory); !ok) return ok;
      continue;
    }
    if (image.depth() != CV_8U && image.depth() != CV_16U && image.depth() != CV_32F)
      return std::unexpected(frame_error(
          request,
          "has an unsupported pixel type; frames are 8- or 16-bit PNG or 32-bit float TIFF/EXR"));
    if (image.channels() != 1 && image.channels() != 3)
      return std::unexpected(
          frame_error(request, "has " + std::to_string(image.channels()) +
                                   " channels; frames are grey or colour (no alpha)"));
    if (auto ok = check_like_first(request, image); !ok) return std::unexpected(ok.error());
  }

  const double full = full_scale(first.depth());
  scan.white_level = d.white_level.value_or(full);
  const fs::path json_file = directory / scan_files::kDescription;
  if (first.depth() != CV_32F && scan.white_level > full)
    return std::unexpected(bad_input(json_file, "white_level",
                                     "is " + std::to_string(scan.white_level) +
                                         " but the frames are " + depth_name(first.depth()) +
                                         " (full scale " + std::to_string(full) + ")"));
  if (scan.description.black_level >= scan.white_level)
    return std::unexpected(bad_input(json_file, "black_level", "must be below the white level"));
  for (std::size_t i = 0; i < d.lights.size(); ++i)
    if (d.lights[i].intensity_is_rgb && first.channels() == 1)
      return std::unexpected(bad_input(json_file, "lights[" + std::to_string(i) + "].intensity",
                                       "gives [r, g, b] but the frames are grey; give one number"));
  return {};
}

// A ground-truth image, read.
Result<cv::Mat> read_truth_image(const ImageRequest& request, const fs::path& directory) {
  return request.key == "ground_truth.normal"
             ? read_vector_exr(directory / request.name, request.key)
             : read_image(directory / request.name, request.key);
}

// A frame psrig's PNG path can decode a band at a time, allocated for it
// and left to `bands`; false for any other (read whole then).
bool leave_to_bands(const ImageRequest& request, const fs::path& directory,
                    FrameBands::State::Frame& frame) {
  if (!request.key.starts_with("lights[")) return false;
  const fs::path file = directory / request.name;
  auto reader = png::Reader::open(file);
  if (!reader) return false;
  *request.destination = cv::Mat(reader->size(), reader->type());  // not decoded yet
  frame.file = file;
  frame.key = request.key;
  frame.data = request.destination->data;
  frame.step = request.destination->step[0];
  frame.size = reader->size();
  frame.type = reader->type();
  frame.reader.emplace(std::move(*reader));
  return true;
}

// With `bands`, the frames it can decode a band at a time are left to it.
Result<Scan> read_scan_unguarded(const fs::path& directory, bool with_truth,
                                 FrameBands::State* bands = nullptr) {
  auto description = read_scan_description(directory);
  if (!description) return std::unexpected(description.error());

  Scan scan;
  scan.description = std::move(*description);
  const auto& d = scan.description;
  scan.frames.resize(d.lights.size());
  scan.flats.resize(d.flats.size());

  std::vector<ImageRequest> requests = image_requests(scan, with_truth);
  if (bands) bands->frames.resize(scan.frames.size());

  // Decoding dominates reading time, so the files are decoded in parallel;
  // the first error in request order is the one reported.
  std::vector<std::optional<Error>> errors(requests.size());
  parallel_chunks(static_cast<int>(requests.size()), 1, [&](int begin, int end) {
    for (int i = begin; i < end; ++i) {
      const auto& request = requests[i];
      if (bands && static_cast<std::size_t>(i) < scan.frames.size() &&
          leave_to_bands(request, directory, bands->frames[static_cast<std::size_t>(i)]))
        continue;
      auto image = request.key.starts_with("ground_truth")
                       ? read_truth_image(request, directory)
                       : read_image(directory / request.name, request.key);
      if (image)
        *request.destination = std::move(*image);
      else
        errors[i] = image.error();
    }
  });
  for (auto& error : errors)
    if (error) return std::unexpected(*error);

  if (auto ok = check_images(scan, requests, directory); !ok) return std::unexpected(ok.error());
  return scan;
}

}  // namespace

Result<Scan> as_stored(Scan scan, const fs::path& directory) {
  try {
    auto description =
        DescriptionParser(directory / scan_files::kDescription).parse(scan_json(scan), directory);
    if (!description) return std::unexpected(description.error());
    scan.description = std::move(*description);
    const auto requests = image_requests(scan);
    for (const auto& request : requests)
      if (request.destination->empty())
        return std::unexpected(
            internal_error("as_stored: the scan has no image for " + request.key));
    if (auto ok = check_images(scan, requests, directory); !ok) return std::unexpected(ok.error());
    return scan;
  } catch (const std::exception& e) {  // out of memory, or a library throwing where it should not
    return std::unexpected(internal_error(directory.string() + ": " + e.what()));
  }
}

Result<Scan> read_scan(const fs::path& directory, ScanImages images) {
  try {
    return read_scan_unguarded(directory, images == ScanImages::all);
  } catch (const std::exception& e) {  // out of memory, or a library throwing where it should not
    return std::unexpected(
        internal_error(directory.string() + ": reading the scan failed: " + e.what()));
  }
}

Status read_ground_truth(Scan& scan, GroundTruth which, cv::Size frames) {
  const auto& d = scan.description;
  const bool normal = which == GroundTruth::normal;
  const std::optional<std::string>& name = normal ? d.ground_truth_normal : d.ground_truth_height;
  cv::Mat& destination = normal ? scan.ground_truth_normal : scan.ground_truth_height;
  if (!name || !destination.empty()) return {};
  const ImageRequest request{*name, normal ? "ground_truth.normal" : "ground_truth.height",
                             &destination};
  try {
    auto image = read_truth_image(request, d.directory);
    if (!image) return std::unexpected(image.error());
    if (auto ok = check_ground_truth(request, *image, frames, d.directory); !ok) return ok;
    destination = std::move(*image);
    return {};
  } catch (const std::exception& e) {  // out of memory
    return std::unexpected(
        internal_error(d.directory.string() + ": reading the scan failed: " + e.what()));
  }
}

Result<BandedScan> read_scan_by_band(const fs::path& directory, ScanImages images) {
  try {
    auto state = std::make_unique<FrameBands::State>();
    auto scan = read_scan_unguarded(directory, images == ScanImages::all, state.get());
    if (!scan) return std::unexpected(scan.error());
    return BandedScan{std::move(*scan), FrameBands(std::move(state))};
  } catch (const std::exception& e) {  // out of memory, or a library throwing where it should not
    return std::unexpected(
        internal_error(directory.string() + ": reading the scan failed: " + e.what()));
  }
}

}  // namespace psrig::formats
