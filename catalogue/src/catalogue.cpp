#include "psrig/catalogue/catalogue.h"

#include <chrono>
#include <ctime>
#include <regex>

#include "postgres_catalogue.h"
#include "sqlite_catalogue.h"

namespace psrig::catalogue {

const char* to_string(ScanStatus status) {
  switch (status) {
    case ScanStatus::queued:
      return "queued";
    case ScanStatus::running:
      return "running";
    case ScanStatus::done:
      return "done";
    case ScanStatus::failed:
      return "failed";
    case ScanStatus::aborted:
      return "aborted";
  }
  return "unknown";
}

std::optional<ScanStatus> parse_scan_status(const std::string& text) {
  for (auto status : {ScanStatus::queued, ScanStatus::running, ScanStatus::done, ScanStatus::failed,
                      ScanStatus::aborted})
    if (text == to_string(status)) return status;
  return std::nullopt;
}

std::string utc_timestamp_now() {
  const std::time_t now = std::time(nullptr);
  std::tm utc{};
  gmtime_r(&now, &utc);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &utc);
  return text;
}

std::optional<std::string> normalise_timestamp(const std::string& text, bool end_of_day) {
  static const std::regex form(
      R"((\d{4})-(\d{2})-(\d{2})(?:[T ](\d{2}):(\d{2}):(\d{2})(\.\d+)?(Z|\+00:00|\+0000)?)?)");
  std::smatch match;
  if (!std::regex_match(text, match, form)) return std::nullopt;
  const auto number = [&](int i) { return static_cast<unsigned>(std::stoul(match[i].str())); };
  // A day of the calendar (the month's length, leap years), not just digits.
  const std::chrono::year_month_day day{std::chrono::year{static_cast<int>(number(1))},
                                        std::chrono::month{number(2)}, std::chrono::day{number(3)}};
  if (!day.ok()) return std::nullopt;
  const std::string date = match[1].str() + "-" + match[2].str() + "-" + match[3].str();
  if (!match[4].matched) return date + (end_of_day ? "T23:59:59Z" : "T00:00:00Z");
  // A time of day: the catalogue writes no leap second (:60), nor takes one.
  if (number(4) > 23 || number(5) > 59 || number(6) > 59) return std::nullopt;
  return date + "T" + match[4].str() + ":" + match[5].str() + ":" + match[6].str() + "Z";
}

CatalogueOptions catalogue_options(const config::RigConfig& config) {
  CatalogueOptions options;
  options.storage_root = config.storage.shared_root;
  options.rig_root = config.storage.root;
  options.url = config.catalogue.url;
  options.rig_name = config.daemon.rig_name;
  options.journal = config.catalogue.journal;
  return options;
}

Result<std::unique_ptr<Catalogue>> Catalogue::open(const std::filesystem::path& storage_root) {
  return SqliteCatalogue::open(storage_root, config::host_name());
}

Result<std::unique_ptr<Catalogue>> open_catalogue(const CatalogueOptions& options) {
  config::CatalogueConfig which;
  which.url = options.url;
  if (config::is_shared_catalogue(which)) return PostgresCatalogue::open(options);
  return SqliteCatalogue::open(options.storage_root, options.rig_name);
}

}  // namespace psrig::catalogue
