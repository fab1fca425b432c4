// What the calibration procedures share (procedure_steps.h).

#include "procedure_steps.h"

namespace psrig::rig {

Result<SphereSet> load_folder(const std::string& role, const fs::path& folder,
                              const std::string& mask_override, int frames_per_light,
                              formats::Encoding encoding) {
  SphereSet set;
  set.role = role;
  set.source = folder;
  auto listed = calibration::list_image_folder(folder);
  if (!listed) return std::unexpected(listed.error());
  const std::size_t count = listed->images.size();
  if (count % static_cast<std::size_t>(frames_per_light) != 0)
    return std::unexpected(
        bad_input(folder, "--frames",
                  "holds " + std::to_string(count) + " images, not a whole number of lights at " +
                      std::to_string(frames_per_light) +
                      " frames each; give --frames to match, or remove the extra images"));
  if (count / frames_per_light < 3)
    return std::unexpected(bad_input(folder, "",
                                     "holds images of " + std::to_string(count / frames_per_light) +
                                         " lights; a calibration needs 3 or more"));
  set.files = listed->images;
  for (std::size_t i = 0; i < count; ++i) {
    auto image = calibration::read_linear_grey(listed->images[i], encoding);
    if (!image) return std::unexpected(image.error());
    if (i % static_cast<std::size_t>(frames_per_light) == 0) set.lights.emplace_back();
    set.lights.back().frames.push_back({*image, listed->images[i]});
  }
  if (!mask_override.empty())
    set.mask_file = mask_override;
  else
    set.mask_file = listed->mask;
  if (set.mask_file) {
    auto mask = calibration::read_mask(*set.mask_file, "--mask");
    if (!mask) return std::unexpected(mask.error());
    if (mask->size() != set.lights.front().frames.front().image.size())
      return std::unexpected(bad_input(*set.mask_file, "--mask",
                                       "differs in size from the images; give the sphere's mask "
                                       "for these images"));
    set.mask = *mask;
  }
  return set;
}

// A frame as stored, in linear float (its channels kept).
cv::Mat linearised(const processing::CodeLineariser& lineariser, const cv::Mat& stored) {
  const cv::Mat continuous = stored.isContinuous() ? stored : stored.clone();
  cv::Mat linear(continuous.size(), CV_MAKETYPE(CV_32F, continuous.channels()));
  lineariser.convert(continuous.data, static_cast<int>(continuous.total()) * continuous.channels(),
                     linear.ptr<float>());
  return linear;
}

// Scans the sequencer wrote, as frames per light: linear, dark subtracted.
Result<SphereSet> load_captures(const std::string& role, const std::vector<fs::path>& scans) {
  SphereSet set;
  set.role = role;
  set.source = scans.front().parent_path();
  for (const auto& directory : scans) {
    auto scan = formats::read_scan(directory);
    if (!scan) return std::unexpected(scan.error());
    const auto& d = scan->description;
    const processing::CodeLineariser lineariser(formats::Encoding::linear, d.black_level,
                                                scan->white_level, scan->depth());
    const auto linear_grey = [&](const cv::Mat& stored) {
      cv::Mat linear = linearised(lineariser, stored);
      if (linear.channels() == 3)
        cv::transform(linear, linear, cv::Matx13f(1.f / 3, 1.f / 3, 1.f / 3));
      return linear;
    };
    const cv::Mat dark = scan->dark.empty() ? cv::Mat() : linear_grey(scan->dark);
    if (set.lights.empty()) set.lights.resize(scan->frames.size());
    for (std::size_t k = 0; k < scan->frames.size(); ++k) {
      cv::Mat image = linear_grey(scan->frames[k]);
      if (!dark.empty()) image -= dark;
      const fs::path file = directory / d.lights[k].image;
      set.lights[k].frames.push_back({image, file});
      set.files.push_back(file);
    }
  }
  return set;
}

Result<calibration::Circle> locate(const SphereSet& set) {
  std::vector<cv::Mat> all;
  for (const auto& light : set.lights)
    for (const auto& frame : light.frames)
      all.push_back(frame.image);
  return calibration::find_sphere(all, set.mask, set.mask_file ? *set.mask_file : set.source);
}

Result<calibration::LightCalibration> compute(const SphereSet* chrome, const SphereSet* matte,
                                              const calibration::CameraModel& camera,
                                              double saturation) {
  calibration::LightCalibration result;
  result.camera = camera;
  result.method = chrome && matte ? "chrome+matte" : chrome ? "chrome" : "matte";
  if (chrome && matte && chrome->lights.size() != matte->lights.size())
    return std::unexpected(bad_input(matte->source, "--matte",
                                     "holds images of " + std::to_string(matte->lights.size()) +
                                         " lights but " + chrome->source.string() + " of " +
                                         std::to_string(chrome->lights.size()) +
                                         "; give both spheres under the same lights"));
  if (chrome) {
    auto sphere = locate(*chrome);
    if (!sphere) return std::unexpected(sphere.error());
    result.chrome_sphere = *sphere;
    auto lights = calibration::calibrate_chrome(chrome->lights, *sphere, camera, saturation);
    if (!lights) return std::unexpected(lights.error());
    result.chrome = *lights;
  }
  if (matte) {
    auto sphere = locate(*matte);
    if (!sphere) return std::unexpected(sphere.error());
    result.matte_sphere = *sphere;
    auto lights = calibration::calibrate_matte(matte->lights, *sphere, camera, saturation);
    if (!lights) return std::unexpected(lights.error());
    result.matte = *lights;
  }
  return result;
}

nlohmann::json describe_sources(const SphereSet& set, const fs::path& relative_to) {
  nlohmann::json files = nlohmann::json::array();
  const auto name = [&](const fs::path& file) {
    return relative_to.empty() ? fs::absolute(file).lexically_normal().string()
                               : file.lexically_relative(relative_to).string();
  };
  for (const auto& file : set.files)
    files.push_back(name(file));
  std::size_t frames = set.lights.empty() ? 0 : set.lights.front().frames.size();
  return {{"images", files},
          {"frames_per_light", frames},
          {"mask", set.mask_file ? nlohmann::json(name(*set.mask_file)) : nlohmann::json(nullptr)}};
}

// Copies a set's files into `captures/<role>/` of a store version.
Result<SphereSet> copy_into(const SphereSet& set, const fs::path& version) {
  SphereSet copied = set;
  const fs::path directory = version / calibration::kCapturesDirectory / set.role;
  std::error_code ec;
  fs::create_directories(directory, ec);
  if (ec) return std::unexpected(io_error(directory, "cannot create: " + ec.message()));
  copied.files.clear();
  for (const auto& file : set.files) {
    const fs::path target = directory / file.filename();
    fs::copy_file(file, target, ec);
    if (ec)
      return std::unexpected(
          io_error(target, "cannot copy " + file.string() + ": " + ec.message()));
    copied.files.push_back(target);
  }
  if (set.mask_file) {
    const fs::path target = directory / set.mask_file->filename();
    fs::copy_file(*set.mask_file, target, ec);
    if (ec) return std::unexpected(io_error(target, "cannot copy: " + ec.message()));
    copied.mask_file = target;
  }
  return copied;
}

// Divides each light's frames by the current calibration's flat for it,
// smoothed and scaled to mean 1 (so relative intensities stay). Returns
// the calibration.json whose flats were used, when they were.
std::optional<std::string> divide_by_current_flats(const calibration::CalibrationStore& store,
                                                   SphereSet& set) {
  const auto file = store.current();
  if (!file) return std::nullopt;
  auto current = calibration::read_calibration(*file);
  if (!current || current->flat_images.size() != set.lights.size()) return std::nullopt;
  std::vector<cv::Mat> gains;
  for (std::size_t k = 0; k < set.lights.size(); ++k) {
    cv::Mat flat = cv::imread(current->flat_images[k].string(), cv::IMREAD_UNCHANGED);
    if (flat.empty() || set.lights[k].frames.empty() ||
        flat.size() != set.lights[k].frames.front().image.size())
      return std::nullopt;
    flat.convertTo(flat, CV_32F);
    if (flat.channels() == 3) cv::transform(flat, flat, cv::Matx13f(1.f / 3, 1.f / 3, 1.f / 3));
    cv::GaussianBlur(flat, flat, cv::Size(), 2.0);
    const double mean = cv::mean(flat)[0];
    if (!(mean > 0)) return std::nullopt;
    cv::max(flat / mean, 0.05, flat);
    gains.push_back(flat);
  }
  for (std::size_t k = 0; k < set.lights.size(); ++k)
    for (auto& frame : set.lights[k].frames)
      frame.image = frame.image / gains[k];
  return file->string();
}

double round_to(double value, double step) {
  return std::round(value / step) * step;
}

// The LEDs' positions from the sphere's places, as calibration.json's
// led_positions_mm section; bad_input when the sphere did not move.
// A new version's calibration.json written and the version committed.
Result<CalibrationOutcome> commit_version(formats::AtomicDirectory staging, const std::string& kind,
                                          const nlohmann::json& document) {
  const std::string text = document.dump(2) + "\n";
  if (auto ok = calibration::write_new_file(staging.path() / calibration::kCalibrationFile, text);
      !ok)
    return std::unexpected(ok.error());
  const fs::path target = staging.target();
  if (auto ok = staging.commit(formats::AtomicDirectory::Existing::refuse, true); !ok)
    return std::unexpected(ok.error());
  return CalibrationOutcome{kind, target / calibration::kCalibrationFile, document};
}

Result<CalibrationOutcome> write_to_store(const config::RigConfig& config,
                                          formats::AtomicDirectory staging,
                                          calibration::LightCalibration& result,
                                          const nlohmann::json& led_positions) {
  nlohmann::json document = calibration::to_json(result, calibration::utc_now());
  // The sections this does not measure (the flat field, …) carry over from
  // the current version.
  const calibration::CalibrationStore store(config.storage.root);
  if (const auto current_file = store.current()) {
    if (auto current = calibration::read_calibration(*current_file)) {
      if (auto carried = calibration::carry_forward(*current, "lights")) {
        for (const char* section : {"flat", "colour", "scale", "led_positions_mm"})
          document[section] = (*carried)[section];
        document["contains"] = (*carried)["contains"];
      }
    }
  }
  if (!led_positions.is_null()) {
    document["led_positions_mm"] = led_positions;
    nlohmann::json contains = nlohmann::json::array();
    for (const char* section : {"lights", "flat", "colour", "scale", "led_positions_mm"})
      if (document.contains(section) && !document[section].is_null()) contains.push_back(section);
    document["contains"] = contains;
  }
  return commit_version(std::move(staging), "lights", document);
}

void tell(const CalibrationRequest& request, const std::string& step) {
  if (request.progress) request.progress(step);
}

// ---- what flat, scale and colour share ----

Result<Extension> extend_current(const config::RigConfig& config,
                                 const calibration::CalibrationStore& store,
                                 const std::string& kind) {
  const auto current_file = store.current();
  if (!current_file)
    return std::unexpected(bad_input(config.source, "storage.root",
                                     "has no light calibration (" + store.directory().string() +
                                         "): run psrig calibrate lights first; the " + kind +
                                         " is stored with the lights"));
  auto current = calibration::read_calibration(*current_file);
  if (!current) return std::unexpected(current.error());
  auto document = calibration::carry_forward(*current, kind);
  if (!document) return std::unexpected(document.error());
  return Extension{*current_file, std::move(*current), std::move(*document)};
}

// The simulated rig puts `target` under its camera in place of the swatch;
// a target named in [sim] target stays.
config::RigConfig with_sim_target(const config::RigConfig& config, const std::string& target) {
  config::RigConfig placed = config;
  if (placed.camera.backend == "sim" && placed.sim.target == "swatch") placed.sim.target = target;
  return placed;
}

// `frames` captures of what lies under the camera (every LED in turn, the
// dark frame), unprocessed, into captures/NAME-I of the staged version.
Result<std::vector<fs::path>> capture_target(const config::RigConfig& config,
                                             const formats::AtomicDirectory& staging,
                                             const std::string& name, const std::string& sample_id,
                                             const std::string& description, int frames,
                                             const CalibrationRequest& args) {
  auto rig = open_rig(config);
  if (!rig) return std::unexpected(rig.error());
  ScanSequencer sequencer(config, *rig->lights, *rig->camera);
  std::error_code ec;
  fs::create_directories(staging.path() / calibration::kCapturesDirectory, ec);
  std::vector<fs::path> scans;
  for (int i = 0; i < frames; ++i) {
    const std::string count = "capture " + std::to_string(i + 1) + " of " + std::to_string(frames);
    ScanRequest request;
    request.sample_id = sample_id;
    request.description = description + ", " + count;
    request.directory =
        staging.path() / calibration::kCapturesDirectory / (name + "-" + std::to_string(i));
    request.process = false;
    auto outcome = sequencer.capture(request, [&](const ScanProgress& p) {
      tell(args, frames > 1 ? count + ": " + p.step : p.step);
    });
    if (!outcome) return std::unexpected(outcome.error());
    scans.push_back(outcome->directory);
  }
  return scans;
}

// The captures' names in the staged version, as a calibration section's
// "sources" gives them.
nlohmann::json captured_sources(const std::vector<fs::path>& scans,
                                const formats::AtomicDirectory& staging,
                                const config::RigConfig& config) {
  nlohmann::json captures = nlohmann::json::array();
  for (const auto& scan : scans)
    captures.push_back(scan.lexically_relative(staging.path()).string());
  return {{"captures", captures}, {"rig", fs::absolute(config.source).lexically_normal().string()}};
}

// A new version staged for an image already taken (--image), the image
// copied into its captures/KIND/; returns its name there.
Result<std::string> stage_given_image(const calibration::CalibrationStore& store,
                                      const fs::path& image, const std::string& kind,
                                      std::optional<formats::AtomicDirectory>& staging) {
  auto next = store.begin_next();
  if (!next) return std::unexpected(next.error());
  staging.emplace(std::move(*next));
  const fs::path directory = staging->path() / calibration::kCapturesDirectory / kind;
  std::error_code ec;
  fs::create_directories(directory, ec);
  fs::copy_file(image, directory / image.filename(), ec);
  if (ec) return std::unexpected(io_error(directory, "cannot copy the image: " + ec.message()));
  return "captures/" + kind + "/" + image.filename().string();
}

// Every LED's frame of every capture averaged (the target evenly lit),
// linear, dark subtracted, 0..1 of full scale, its channels kept; each
// light's frame times its gain first when `gains` holds one per light
// (the flat field as scans apply it); and where any frame reached full
// scale.
Result<calibration::LinearColourImage> average_captures(const std::vector<fs::path>& scans,
                                                        const std::vector<cv::Mat>& gains) {
  calibration::LinearColourImage out;
  int count = 0;
  for (const auto& directory : scans) {
    auto scan = formats::read_scan(directory);
    if (!scan) return std::unexpected(scan.error());
    const auto& d = scan->description;
    const processing::CodeLineariser lineariser(formats::Encoding::linear, d.black_level,
                                                scan->white_level, scan->depth());
    const cv::Mat dark = scan->dark.empty() ? cv::Mat() : linearised(lineariser, scan->dark);
    for (std::size_t k = 0; k < scan->frames.size(); ++k) {
      cv::Mat image = linearised(lineariser, scan->frames[k]);
      cv::Mat brightest;
      cv::reduce(image.reshape(1, static_cast<int>(image.total())), brightest, 1, cv::REDUCE_MAX);
      const cv::Mat full = brightest.reshape(1, image.rows) >= 0.98f;
      out.saturated = out.saturated.empty() ? full : cv::Mat(out.saturated | full);
      if (!dark.empty()) image -= dark;
      if (!gains.empty()) {
        if (gains.size() != scan->frames.size() || gains[k].size() != image.size() ||
            gains[k].channels() != image.channels())
          return std::unexpected(bad_input(directory, "flat",
                                           "does not fit the rig's current flat field (lights "
                                           "or frame size): run psrig calibrate flat again"));
        image = image.mul(gains[k]);
      }
      out.bgr = out.bgr.empty() ? image : cv::Mat(out.bgr + image);
      ++count;
    }
  }
  if (count > 0) out.bgr /= count;
  return out;
}

}  // namespace psrig::rig
