#include "band_maps.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdint>
#include <functional>
#include <sys/mman.h>
#include <unistd.h>

#include "psrig/analysis/fabric_measure.h"
#include "psrig/base/parallel.h"
#include "psrig/formats/map_encoding.h"
#include "psrig/formats/row_writer.h"
#include "psrig/formats/scan_layout.h"
#include "psrig/processing/colour_correction.h"
#include "stage_tasks.h"

namespace psrig::processing {
namespace {

namespace fs = std::filesystem;
using ColourSpace = formats::ImageMetadata::ColourSpace;

// Rows per band: whole blocks of OpenEXR's compressors (32 lines for PIZ,
// 16 for ZIP), so each band's blocks are compressed as it is written; at
// 12 MP colour 12 MB of albedo per band buffer.
constexpr int kBandRows = 256;

// One solved band: views of the whole planes, and its albedo (colour
// calibrated when the scan says so).
struct Band {
  int first = 0;
  cv::Mat p, q, flags, albedo;
};

// One map file: its writer, and what a band gives it to write.
struct MapStream {
  const char* name;
  formats::RowWriter writer;
  std::function<cv::Mat(const Band&)> rows;
  double ms = 0;
};

Result<std::vector<MapStream>> open_streams(const MapFiles& files, cv::Size size, int channels) {
  std::vector<MapStream> streams;
  const auto open = [&](const char* name, int type, const std::vector<int>& params,
                        const formats::ImageMetadata& metadata,
                        std::function<cv::Mat(const Band&)> rows) -> Status {
    auto writer = formats::RowWriter::open(files.dir / name, size, type, params, metadata);
    if (!writer) return std::unexpected(writer.error());
    streams.push_back({name, std::move(*writer), std::move(rows)});
    return {};
  };
  formats::ImageMetadata normal_meta = files.metadata(ColourSpace::data);
  normal_meta.text.emplace_back(formats::metadata_keys::kNormalConvention, "OpenGL (+Y up)");
  formats::ImageMetadata directx_meta = normal_meta;
  directx_meta.text.back().second = "DirectX (+Y down)";
  // The longest encoders first: the pool takes them first.
  Status ok =
      open(formats::map_files::kAlbedoExr, CV_32FC(channels), files.half_exr,
           files.metadata(ColourSpace::unspecified), [](const Band& band) { return band.albedo; });
  if (ok)
    ok = open(formats::map_files::kNormalPng, CV_16UC3, files.png_out, normal_meta,
              [](const Band& band) { return formats::encode_normal16(band.p, band.q); });
  if (ok && files.options.directx_normal)
    ok = open(formats::map_files::kNormalDirectxPng, CV_16UC3, files.png_out, directx_meta,
              [](const Band& band) {
                return formats::flip_normal_green(formats::encode_normal16(band.p, band.q));
              });
  if (ok)
    ok = open(formats::map_files::kP, CV_32FC1, files.map_exr, files.gradient_meta,
              [](const Band& band) { return band.p; });
  if (ok)
    ok = open(formats::map_files::kQ, CV_32FC1, files.map_exr, files.gradient_meta,
              [](const Band& band) { return band.q; });
  if (ok)
    ok = open(formats::map_files::kAlbedoPng, CV_8UC(channels), files.png_out,
              files.metadata(ColourSpace::colour),
              [](const Band& band) { return formats::encode_albedo_srgb8(band.albedo); });
  if (ok)
    ok = open(formats::map_files::kMask, CV_8UC1, files.png_out, files.metadata(ColourSpace::data),
              [](const Band& band) { return encode_valid_mask(band.flags); });
  if (!ok) return std::unexpected(ok.error());
  return streams;
}

// Rows [0, rows) of `image` given back to the system, whole pages of them:
// the solve has read them, and nothing reads them again. Only where this Mat
// alone holds its pixels (a frame the caller shares is left alone); they
// read as 0 after.
void give_back_rows(const cv::Mat& image, int rows) {
  if (image.empty() || image.u == nullptr || image.u->refcount != 1 || !image.isContinuous())
    return;
  const auto page = static_cast<std::uintptr_t>(::sysconf(_SC_PAGESIZE));
  const auto begin = reinterpret_cast<std::uintptr_t>(image.data);
  const std::uintptr_t end = begin + static_cast<std::uintptr_t>(rows) * image.step[0];
  const std::uintptr_t first = (begin + page - 1) / page * page;
  const std::uintptr_t last = end / page * page;
  if (last > first) ::madvise(reinterpret_cast<void*>(first), last - first, MADV_DONTNEED);
}

}  // namespace

Result<BandStage> solve_and_encode(formats::Scan& scan, formats::FrameBands& frames,
                                   const SolveOptions& options, const MapFiles& files,
                                   const std::optional<cv::Matx33d>& colour, spdlog::logger& log) {
  auto solver = RowSolver::create(scan, options);
  if (!solver) return std::unexpected(solver.error());
  const cv::Size size = scan.size();
  const int channels = scan.channels();
  auto streams = open_streams(files, size, channels);
  if (!streams) return std::unexpected(streams.error());

  BandStage stage;
  SolvedPlanes& planes = stage.planes;
  planes.p.create(size, CV_32F);
  planes.q.create(size, CV_32F);
  planes.residual.create(size, CV_32F);
  planes.flags.create(size, CV_8U);
  const cv::Rect centre = analysis::measured_region(size);
  planes.albedo_centre.create(centre.size(), CV_32FC(channels));

  // Two bands in flight: one being encoded, the next being solved.
  std::array<cv::Mat, 2> albedo;
  for (auto& buffer : albedo)
    buffer.create(std::min(kBandRows, size.height), size.width, CV_32FC(channels));
  std::array<Band, 2> bands;
  const auto solve_band = [&](int index) -> Status {
    Band& band = bands[static_cast<std::size_t>(index % 2)];
    band.first = index * kBandRows;
    const int rows = std::min(kBandRows, size.height - band.first);
    const cv::Range range(band.first, band.first + rows);
    SolveResult out{planes.p.rowRange(range), planes.q.rowRange(range),
                    albedo[static_cast<std::size_t>(index % 2)].rowRange(0, rows),
                    planes.residual.rowRange(range), planes.flags.rowRange(range)};
    solver->solve(band.first, rows, out);
    const int top = std::max(band.first, centre.y);
    const int bottom = std::min(band.first + rows, centre.y + centre.height);
    if (top < bottom)
      out.albedo(cv::Range(top - band.first, bottom - band.first),
                 cv::Range(centre.x, centre.x + centre.width))
          .copyTo(planes.albedo_centre.rowRange(top - centre.y, bottom - centre.y));
    // What the solve has read is given back: the frames' memory goes as the
    // results' comes.
    for (const cv::Mat& frame : scan.frames)
      give_back_rows(frame, band.first + rows);
    give_back_rows(scan.dark, band.first + rows);
    give_back_rows(scan.mask, band.first + rows);
    if (colour) apply_colour_matrix(*colour, out.albedo);  // grey albedo: left as it is
    band.p = out.p;
    band.q = out.q;
    band.flags = out.flags;
    band.albedo = out.albedo;
    return {};
  };

  // Bands in flight: one decoded, the one before it solved, the one before
  // that encoded, side by side on the pool (each solve then on one thread:
  // OpenCV's pool runs one parallel region at a time, stage_tasks.h). The
  // first band's frames are decoded alone; a solve with nothing beside it
  // (whole frames) has every thread.
  const int count = chunk_count(size.height, kBandRows);
  std::vector<double> decode_ms(scan.frames.size(), 0.0);  // each frame's, its tasks one at a time
  const auto decoding = [&](int index, std::vector<StageTask>& tasks) {
    if (index >= count) return;
    const int first = index * kBandRows;
    const int rows = std::min(kBandRows, size.height - first);
    for (std::size_t k = 0; k < scan.frames.size(); ++k)
      if (frames.pending(k))
        tasks.push_back({"decode",
                         [&frames, k, first, rows] { return frames.decode(k, first, rows); },
                         &decode_ms[k]});
  };
  std::vector<StageTask> tasks;
  decoding(0, tasks);
  if (auto ok = run_tasks(tasks, log); !ok) return std::unexpected(ok.error());
  for (int index = -1; index < count; ++index) {
    tasks.clear();
    if (index + 1 < count)
      tasks.push_back(
          {"solve", [&solve_band, index] { return solve_band(index + 1); }, &stage.solve_ms});
    decoding(index + 2, tasks);
    if (index >= 0) {
      const Band& band = bands[static_cast<std::size_t>(index % 2)];
      for (MapStream& stream : *streams)
        tasks.push_back({stream.name,
                         [&stream, &band] { return stream.writer.write(stream.rows(band)); },
                         &stream.ms});
    }
    if (auto ok = run_tasks(tasks, log); !ok) return std::unexpected(ok.error());
  }
  std::vector<StageTask> finishing;
  for (MapStream& stream : *streams)
    finishing.push_back({stream.name, [&stream] { return stream.writer.finish(); }, &stream.ms});
  if (auto ok = run_tasks(finishing, log); !ok) return std::unexpected(ok.error());

  for (double ms : decode_ms)
    stage.decode_ms += ms;
  log.debug("solve: {:.0f} ms in {} bands; decoding frames: {:.0f} ms", stage.solve_ms, count,
            stage.decode_ms);
  for (const MapStream& stream : *streams) {
    log.debug("{}: {:.0f} ms", stream.name, stream.ms);
    stage.encode_ms.emplace_back(stream.name, stream.ms);
  }
  return stage;
}

}  // namespace psrig::processing
