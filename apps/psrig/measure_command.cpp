// psrig measure MAPS_DIR: the fabric's repeat, densities and skew from its
// maps (analysis/maps_fabric.h); with --chart, a knit's stitch chart read
// off them too, its stitches counted.

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>

#include "command.h"
#include "psrig/analysis/chart_inference.h"
#include "psrig/analysis/fabric_measure.h"
#include "psrig/analysis/maps_fabric.h"
#include "psrig/formats/maps_reader.h"

namespace psrig::cli {
namespace {

namespace fs = std::filesystem;

struct MeasureArgs {
  std::string maps;
  std::string chart;
  bool json = false;
  bool quiet = false;
};

// The chart as a .chart file, whole or not at all.
Status write_chart(const fs::path& file, const analysis::InferredKnit& knit, const fs::path& maps) {
  char comment[400];
  std::snprintf(comment, sizeof comment,
                "read off %s by psrig measure --chart: %d x %d stitches seen, %.1f %% of them\n"
                "agreeing with this chart; fit %.2f with the chart as the cloth model knits it",
                maps.string().c_str(), knit.columns, knit.rows, 100 * knit.agreement, knit.fit);
  const fs::path staging = file.string() + ".partial";
  {
    std::ofstream out(staging, std::ios::trunc);
    out << cloth::format_stitch_chart(knit.chart, comment);
    if (!out.flush())
      return std::unexpected(io_error(file, "cannot write the chart here (--chart)"));
  }
  std::error_code error;
  fs::rename(staging, file, error);
  if (error) {
    fs::remove(staging, error);
    return std::unexpected(io_error(file, "cannot write the chart here (--chart)"));
  }
  return {};
}

// Every stitch read, a row a string of K and P, the bottom course first.
nlohmann::json stitches_read(const analysis::InferredKnit& knit) {
  nlohmann::json rows = nlohmann::json::array();
  for (int row = 0; row < knit.rows; ++row) {
    std::string text;
    for (int column = 0; column < knit.columns; ++column)
      text += knit.stitches[static_cast<std::size_t>(row * knit.columns + column)] ==
                      cloth::Stitch::knit
                  ? 'K'
                  : 'P';
    rows.push_back(text);
  }
  return rows;
}

nlohmann::json chart_json(const analysis::InferredKnit& knit, const fs::path& file) {
  return {{"file", file.string()},
          {"stitches", {knit.chart.columns, knit.chart.rows}},
          {"palette", knit.chart.palette.size()},
          {"grid", {knit.columns, knit.rows}},
          {"read", stitches_read(knit)},
          {"agreement", knit.agreement},
          {"fit", knit.fit},
          {"lattice_px",
           {{"origin", {knit.lattice.origin_px.x, knit.lattice.origin_px.y}},
            {"next_wale", {knit.lattice.next_wale_px.x, knit.lattice.next_wale_px.y}},
            {"next_course", {knit.lattice.next_course_px.x, knit.lattice.next_course_px.y}}}},
          {"text", cloth::format_stitch_chart(knit.chart)}};
}

}  // namespace

Command add_measure_command(CLI::App& parent) {
  auto args = std::make_shared<MeasureArgs>();
  CLI::App* app = parent.add_subcommand(
      "measure",
      "Measure the fabric on a maps directory: wales/courses or ends/picks per cm, skew");
  app->add_option("maps", args->maps, "Maps directory (psrig process writes one)")->required();
  app->add_option("--chart", args->chart,
                  "Knits: read the stitch chart off the maps into this .chart file, and count "
                  "the stitches in the repeat");
  app->add_flag("--json", args->json, "Print the measurement as JSON (report.json's fabric)");
  app->add_flag("-q,--quiet", args->quiet,
                "Print nothing on success (warnings still go to stderr)");
  return {app, [args] {
            std::vector<std::string> warnings;
            auto maps = formats::read_maps(args->maps, warnings);
            if (!maps) return report_error("measure", maps.error());
            for (const auto& w : warnings)
              std::cerr << "psrig measure: warning: " << w << '\n';
            // Measured anew, never report.json's: this is the explicit step.
            auto m = analysis::measure_maps(*maps);
            if (!m) return report_error("measure", m.error());
            if (!m->periodic)
              std::cerr << "psrig measure: warning: "
                        << (m->notes.empty() ? "no repeat found" : m->notes.back()) << '\n';
            std::optional<analysis::InferredKnit> knit;
            if (!args->chart.empty()) {
              auto inferred = analysis::infer_knit_chart(*maps, *m);
              if (!inferred) {
                Error error = inferred.error();
                error.file = args->maps;
                return report_error("measure", error);
              }
              if (auto written = write_chart(args->chart, *inferred, args->maps); !written)
                return report_error("measure", written.error());
              analysis::count_stitches(*m, *inferred);
              knit = std::move(*inferred);
            }
            if (args->quiet) return 0;
            if (args->json) {
              nlohmann::json j = analysis::to_json(*m);
              if (knit) j["chart"] = chart_json(*knit, args->chart);
              std::printf("%s\n", j.dump(2).c_str());
            } else {
              std::printf("fabric: %s\n", analysis::summary_line(*m).c_str());
              if (knit)
                std::printf("chart: %s (%d x %d stitches, %zu colour%s; %d x %d stitches read, "
                            "%.1f %% agree)\n",
                            args->chart.c_str(), knit->chart.columns, knit->chart.rows,
                            knit->chart.palette.size(), knit->chart.palette.size() == 1 ? "" : "s",
                            knit->columns, knit->rows, 100 * knit->agreement);
              for (const auto& note : m->notes)
                std::printf("  note: %s\n", note.c_str());
              if (knit)
                for (const auto& note : knit->notes)
                  std::printf("  note: %s\n", note.c_str());
            }
            return 0;
          }};
}

}  // namespace psrig::cli
