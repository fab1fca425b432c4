#include "psrig/calibration/image_set.h"

#include <algorithm>
#include <cctype>
#include <system_error>

#include <opencv2/core.hpp>

#include "psrig/formats/image_io.h"
#include "psrig/processing/linearise.h"

namespace psrig::calibration {

namespace fs = std::filesystem;

bool natural_less(const std::string& a, const std::string& b) {
  std::size_t i = 0;
  std::size_t j = 0;
  while (i < a.size() && j < b.size()) {
    if (std::isdigit(static_cast<unsigned char>(a[i])) &&
        std::isdigit(static_cast<unsigned char>(b[j]))) {
      std::size_t ei = i;
      std::size_t ej = j;
      while (ei < a.size() && std::isdigit(static_cast<unsigned char>(a[ei])))
        ++ei;
      while (ej < b.size() && std::isdigit(static_cast<unsigned char>(b[ej])))
        ++ej;
      std::string na = a.substr(i, ei - i);
      std::string nb = b.substr(j, ej - j);
      na.erase(0, std::min(na.find_first_not_of('0'), na.size()));
      nb.erase(0, std::min(nb.find_first_not_of('0'), nb.size()));
      if (na.size() != nb.size()) return na.size() < nb.size();
      if (na != nb) return na < nb;
      i = ei;
      j = ej;
      continue;
    }
    if (a[i] != b[j]) return a[i] < b[j];
    ++i;
    ++j;
  }
  return a.size() - i < b.size() - j;
}

Result<ImageFolder> list_image_folder(const fs::path& directory) {
  std::error_code ec;
  if (!fs::is_directory(directory, ec))
    return std::unexpected(
        bad_input(directory, "", "is not a directory; give the folder that holds the images"));
  ImageFolder folder;
  for (const auto& entry : fs::directory_iterator(directory, ec)) {
    if (!entry.is_regular_file(ec)) continue;
    std::string extension = entry.path().extension().string();
    std::transform(extension.begin(), extension.end(), extension.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    if (extension != ".png" && extension != ".tif" && extension != ".tiff" && extension != ".exr" &&
        extension != ".jpg" && extension != ".jpeg")
      continue;
    std::string stem = entry.path().stem().string();
    std::transform(stem.begin(), stem.end(), stem.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    if (stem.ends_with("mask")) {
      if (folder.mask)
        return std::unexpected(bad_input(directory, "",
                                         "holds two masks (" + folder.mask->filename().string() +
                                             ", " + entry.path().filename().string() +
                                             "); keep one, or name it with --mask"));
      folder.mask = entry.path();
      continue;
    }
    folder.images.push_back(entry.path());
  }
  if (ec) return std::unexpected(io_error(directory, "cannot list: " + ec.message()));
  std::sort(folder.images.begin(), folder.images.end(), [](const fs::path& a, const fs::path& b) {
    return natural_less(a.filename().string(), b.filename().string());
  });
  if (folder.images.empty())
    return std::unexpected(
        bad_input(directory, "",
                  "holds no images (.png, .tif, .tiff, .exr, .jpg); give the folder with one "
                  "image per light"));
  return folder;
}

Result<cv::Mat> read_linear_grey(const fs::path& file, formats::Encoding encoding) {
  auto stored = formats::read_image(file, "");
  if (!stored) return std::unexpected(stored.error());
  const cv::Mat& image = *stored;
  if (image.depth() != CV_8U && image.depth() != CV_16U && image.depth() != CV_32F)
    return std::unexpected(bad_input(
        file, "", "has an unsupported pixel type; give 8- or 16-bit PNG or 32-bit float TIFF/EXR"));
  const double full = formats::full_scale(image.depth());
  const processing::CodeLineariser lineariser(encoding, 0, full, image.depth());
  cv::Mat continuous = image.isContinuous() ? image : image.clone();
  cv::Mat linear(continuous.size(), CV_MAKETYPE(CV_32F, continuous.channels()));
  lineariser.convert(continuous.data, static_cast<int>(continuous.total()) * continuous.channels(),
                     linear.ptr<float>());
  if (linear.channels() == 1) return linear;
  std::vector<cv::Mat> planes;
  cv::split(linear, planes);
  cv::Mat grey = cv::Mat::zeros(linear.size(), CV_32F);
  const int colours = std::min(3, linear.channels());
  for (int c = 0; c < colours; ++c)
    grey += planes[c];
  return cv::Mat(grey / colours);
}

Result<cv::Mat> read_mask(const fs::path& file, const std::string& key) {
  auto stored = formats::read_image(file, key);
  if (!stored) return std::unexpected(stored.error());
  cv::Mat image = *stored;
  if (image.channels() > 1) {
    std::vector<cv::Mat> planes;
    cv::split(image, planes);
    const int colours = std::min(3, image.channels());
    for (int c = 1; c < colours; ++c)
      if (cv::countNonZero(planes[c] != planes[0]) > 0)
        return std::unexpected(bad_input(
            file, key,
            "is a colour image whose channels differ; a mask is grey (or RGB with R = G = B): "
            "nonzero = use. Save it as a grey PNG"));
    image = planes[0];
  }
  cv::Mat mask;
  cv::compare(image, 0, mask, cv::CMP_NE);
  return mask;
}

}  // namespace psrig::calibration
