// psrig measure MAPS_DIR: the fabric's repeat, densities and skew from its
// maps (processing/fabric_measure.h).

#include <cstdio>
#include <iostream>
#include <memory>

#include "command.h"
#include "psrig/processing/fabric_measure.h"
#include "psrig/processing/maps_reader.h"

namespace psrig::capture::cli {
namespace {

struct MeasureArgs {
  std::string maps;
  bool json = false;
  bool quiet = false;
};

}  // namespace

Command add_measure_command(CLI::App& parent) {
  auto args = std::make_shared<MeasureArgs>();
  CLI::App* app = parent.add_subcommand(
      "measure",
      "Measure the fabric on a maps directory: wales/courses or ends/picks per cm, skew");
  app->add_option("maps", args->maps, "Maps directory (psrig process writes one)")->required();
  app->add_flag("--json", args->json, "Print the measurement as JSON (report.json's fabric)");
  app->add_flag("-q,--quiet", args->quiet,
                "Print nothing on success (warnings still go to stderr)");
  return {app, [args] {
            std::vector<std::string> warnings;
            auto maps = processing::read_maps(args->maps, warnings);
            if (!maps) return report_error("measure", maps.error());
            for (const auto& w : warnings)
              std::cerr << "psrig measure: warning: " << w << '\n';
            processing::MeasureOptions options;
            options.pixel_size_mm = maps->pixel_size_mm;
            options.hints = processing::fabric_hints(maps->scan_document);
            const cv::Mat& height = maps->height.empty() ? maps->p : maps->height;
            auto m = processing::measure_fabric(height, maps->albedo, options);
            if (!m) return report_error("measure", m.error());
            if (!m->periodic)
              std::cerr << "psrig measure: warning: "
                        << (m->notes.empty() ? "no repeat found" : m->notes.back()) << '\n';
            if (args->quiet) return 0;
            if (args->json) {
              std::printf("%s\n", processing::to_json(*m).dump(2).c_str());
            } else {
              std::printf("fabric: %s\n", processing::summary_line(*m).c_str());
              for (const auto& note : m->notes)
                std::printf("  note: %s\n", note.c_str());
            }
            return 0;
          }};
}

}  // namespace psrig::capture::cli
