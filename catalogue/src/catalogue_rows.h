#pragma once
// What the two catalogue backends share of their SQL: the columns a row is
// read from and the entry they make, a search's WHERE clause in either
// dialect, the report's figures kept as columns, and paths kept relative
// to the storage root.

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "psrig/catalogue/catalogue.h"

namespace psrig::catalogue::rows {

// The columns every backend selects for an entry, in this order (each as
// text, NULL as nothing): id, rig, sample_id, description, source, status,
// created, started, finished, error_code, error_message, scan_path,
// maps_path, report (JSON), tags (a JSON array in the order they were given).
inline constexpr int kEntryColumns = 15;
[[nodiscard]] CatalogueEntry entry_from(const std::vector<std::optional<std::string>>& columns,
                                        const std::filesystem::path& root);

// How a backend spells what differs: its parameters, a case-blind LIKE and
// a number parameter.
struct Dialect {
  // The n-th parameter (1-based): "?" or "$n".
  std::string (*parameter)(int n);
  const char* like;  // "LIKE" (SQLite: case-blind for ASCII) or "ILIKE"
  // A parameter bound as text, read as a number.
  std::string (*number)(const std::string& parameter);
};
[[nodiscard]] const Dialect& sqlite_dialect();
[[nodiscard]] const Dialect& postgres_dialect();

// A search's WHERE clause (empty, or " WHERE …" over scans `s` and
// scan_tags `t`) and the texts it binds, in order, numbered from 1.
struct Filter {
  std::string where;
  std::vector<std::string> texts;
};
[[nodiscard]] Filter filter_of(const CatalogueQuery& query, const Dialect& dialect);

// The report's figures the scans table keeps as columns (searchable,
// sortable): the mean angular error against the ground truth, the mean
// residual, the height range, the processing time.
struct ReportFigures {
  std::optional<double> angular_error_deg, residual_mean, height_range, total_ms;
};
[[nodiscard]] ReportFigures figures_of(const nlohmann::json& report);

// `path` made absolute under `root`, if it lies inside it.
[[nodiscard]] std::optional<std::filesystem::path> inside_root(const std::filesystem::path& root,
                                                               const std::filesystem::path& path);

}  // namespace psrig::catalogue::rows
