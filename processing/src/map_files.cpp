#include "map_files.h"

#include <cstdio>

#include "psrig/formats/storage_options.h"

namespace psrig::processing {

std::string metadata_number(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.9g", v);
  return text;
}

formats::ImageMetadata MapFiles::metadata(formats::ImageMetadata::ColourSpace space) const {
  formats::ImageMetadata m;
  m.pixel_size_mm = scan.description.pixel_size_mm;
  m.colour_space = space;
  if (!scan.description.sample_id.empty())
    m.text.emplace_back(formats::metadata_keys::kSample, scan.description.sample_id);
  const auto& doc = scan.description.document;
  if (doc.contains("capture") && doc["capture"].is_object() && doc["capture"].contains("started") &&
      doc["capture"]["started"].is_string())
    m.text.emplace_back(formats::metadata_keys::kScanTime,
                        doc["capture"]["started"].get<std::string>());
  if (in_mm) m.text.emplace_back(formats::metadata_keys::kPixelSize, metadata_number(pixel_size));
  m.text.emplace_back(formats::metadata_keys::kSoftware, "psrig");
  return m;
}

MapFiles map_files(const formats::Scan& scan, const ProcessOptions& options,
                   const std::filesystem::path& dir) {
  const auto& description = scan.description;
  const auto& storage = options.storage;
  MapFiles files{
      .scan = scan,
      .options = options,
      .dir = dir,
      .pixel_size = description.pixel_size_mm.value_or(1.0),
      .in_mm = description.pixel_size_mm.has_value(),
      .png_out = formats::png_params(storage.png_level),
      .half_exr = formats::exr_params(storage.exr_compression, true),
      .map_exr = formats::exr_params(storage.exr_compression,
                                     storage.map_precision == formats::MapPrecision::half),
      .gradient_meta = {},
  };
  files.gradient_meta = files.metadata(formats::ImageMetadata::ColourSpace::unspecified);
  files.gradient_meta.text.emplace_back(formats::metadata_keys::kUnits,
                                        "dz/dx, dz/dy (y up), unitless");
  return files;
}

}  // namespace psrig::processing
