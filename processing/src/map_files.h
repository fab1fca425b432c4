#pragma once
// What every file of a maps directory carries and how it is stored: the
// scan's metadata in each (formats/image_metadata.h), the [storage]
// compression and precision, where the files go. The band stage
// (band_maps.h) and the height maps (pipeline.cpp) write through it.

#include <filesystem>
#include <vector>

#include "psrig/formats/image_metadata.h"
#include "psrig/formats/scan.h"
#include "psrig/processing/pipeline.h"

namespace psrig::processing {

struct MapFiles {
  const formats::Scan& scan;
  const ProcessOptions& options;
  std::filesystem::path dir;
  double pixel_size = 1.0;  // mm, or 1 px without the scan's pixel size
  bool in_mm = false;
  // Every map losslessly compressed as [storage] says (report.json's
  // options record it).
  std::vector<int> png_out;
  // Half floats hold albedo (linear, about 0..1) to 1 part in 2000, at half
  // the bytes of a float map; p, q and height as [storage] map_precision
  // says (storage_options.h: why half is the default).
  std::vector<int> half_exr;
  std::vector<int> map_exr;
  formats::ImageMetadata gradient_meta;

  // What every map file says about itself (image_metadata.h): its scale,
  // the sample and when it was scanned.
  [[nodiscard]] formats::ImageMetadata metadata(formats::ImageMetadata::ColourSpace space) const;
};

[[nodiscard]] MapFiles map_files(const formats::Scan& scan, const ProcessOptions& options,
                                 const std::filesystem::path& dir);

// A number for a text chunk: enough digits to give the double back.
[[nodiscard]] std::string metadata_number(double v);

}  // namespace psrig::processing
