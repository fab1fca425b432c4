// psrig tile MAPS_DIR: the seamless tile, a whole number of the fabric's
// repeats (processing/seamless_tile.h), as a directory of maps + tile.json.

#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>

#include "command.h"
#include "psrig/analysis/fabric_measure.h"
#include "psrig/analysis/seamless_tile.h"
#include "psrig/formats/maps_reader.h"

namespace psrig::cli {
namespace {

struct TileArgs {
  std::string maps;
  std::string out;
  int repeats = 0;
  bool quiet = false;
};

}  // namespace

Command add_tile_command(CLI::App& parent) {
  auto args = std::make_shared<TileArgs>();
  CLI::App* app =
      parent.add_subcommand("tile", "Cut a seamless tile of whole repeats from a maps directory");
  app->add_option("maps", args->maps, "Maps directory (psrig process writes one)")->required();
  app->add_option("--out", args->out, "Tile directory to write (default: MAPS_DIR/tile)");
  app->add_option("--repeats", args->repeats,
                  "Repeats each way (default: as many whole repeats as the scan holds)")
      ->check(CLI::Range(1, 1000));
  app->add_flag("-q,--quiet", args->quiet,
                "Print nothing on success (warnings still go to stderr)");
  return {app, [args] {
            std::vector<std::string> warnings;
            auto maps = formats::read_maps(args->maps, warnings);
            if (!maps) return report_error("tile", maps.error());
            analysis::TileOptions options;
            options.repeats = args->repeats;
            auto tile = analysis::cut_tile(*maps, options, warnings);
            if (!tile) return report_error("tile", tile.error());
            for (const auto& w : warnings)
              std::cerr << "psrig tile: warning: " << w << '\n';
            const std::filesystem::path out =
                args->out.empty()
                    ? std::filesystem::path(args->maps) / formats::tile_files::kDirectory
                    : std::filesystem::path(args->out);
            if (auto ok = analysis::write_tile(*tile, out); !ok)
              return report_error("tile", ok.error());
            if (args->quiet) return 0;
            const bool mm = tile->pixel_size_mm.has_value();
            std::printf("tile: %s\n", out.string().c_str());
            std::printf("%d x %d repeats, %d x %d px, %.3f x %.3f %s%s\n", tile->repeats_u,
                        tile->repeats_v, tile->maps.p.cols, tile->maps.p.rows, tile->width,
                        tile->height, mm ? "mm" : "px", tile->periodic ? "" : " (whole scan)");
            std::printf(
                "seam: %.3g (second difference of the %s across it), interior p95 %.3g: %s\n",
                tile->seam.value, tile->seam.map.c_str(), tile->seam.bound,
                tile->seam.passed() ? "invisible" : "visible");
            return 0;
          }};
}

}  // namespace psrig::cli
