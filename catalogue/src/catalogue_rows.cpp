#include "catalogue_rows.h"

namespace psrig::catalogue::rows {
namespace {

namespace fs = std::filesystem;

std::optional<double> number_at(const nlohmann::json& report,
                                const nlohmann::json::json_pointer& at) {
  if (!report.is_object() || !report.contains(at)) return std::nullopt;
  const auto& value = report.at(at);
  if (!value.is_number()) return std::nullopt;
  return value.get<double>();
}

// `text` for LIKE, its own % and _ taken literally.
std::string like_pattern(const std::string& text) {
  std::string pattern = "%";
  for (const char c : text) {
    if (c == '%' || c == '_' || c == '\\') pattern += '\\';
    pattern += c;
  }
  return pattern + "%";
}

}  // namespace

CatalogueEntry entry_from(const std::vector<std::optional<std::string>>& columns,
                          const fs::path& root) {
  const auto text = [&](int i) { return columns.at(i).value_or(""); };
  const auto integer = [&](int i) -> std::int64_t {
    const std::string value = text(i);
    return value.empty() ? 0 : std::stoll(value);
  };
  CatalogueEntry e;
  e.id = integer(0);
  e.rig = text(1);
  e.sample_id = text(2);
  e.description = text(3);
  e.source = text(4);
  e.status = parse_scan_status(text(5)).value_or(ScanStatus::failed);
  e.created = text(6);
  e.started = text(7);
  e.finished = text(8);
  e.error_code = static_cast<ScanErrorCode>(integer(9));
  e.error_message = text(10);
  if (const auto scan = text(11); !scan.empty()) e.scan_directory = root / scan;
  if (const auto maps = text(12); !maps.empty()) e.maps_directory = root / maps;
  if (columns.at(13)) {
    e.report = nlohmann::json::parse(*columns[13], nullptr, false);
    if (e.report.is_discarded()) e.report = nullptr;
  }
  const auto tags = nlohmann::json::parse(text(14), nullptr, false);
  if (tags.is_array())
    for (const auto& tag : tags)
      if (tag.is_string()) e.tags.push_back(tag.get<std::string>());
  return e;
}

const Dialect& sqlite_dialect() {
  static const Dialect dialect{[](int) { return std::string("?"); }, "LIKE",
                               [](const std::string& p) { return "CAST(" + p + " AS REAL)"; }};
  return dialect;
}

const Dialect& postgres_dialect() {
  static const Dialect dialect{[](int n) { return "$" + std::to_string(n); }, "ILIKE",
                               [](const std::string& p) { return p + "::double precision"; }};
  return dialect;
}

Filter filter_of(const CatalogueQuery& query, const Dialect& dialect) {
  Filter f;
  const auto next = [&] { return dialect.parameter(static_cast<int>(f.texts.size()) + 1); };
  const auto condition = [&](const std::string& sql) {
    f.where += (f.where.empty() ? " WHERE " : " AND ") + sql;
  };
  const auto bind = [&](const std::string& value) {
    std::string placeholder = next();
    f.texts.push_back(value);
    return placeholder;
  };
  const std::string like = std::string(" ") + dialect.like + " ";
  if (query.text) {
    const std::string pattern = like_pattern(*query.text);
    const std::string a = bind(pattern), b = bind(pattern), c = bind(pattern);
    condition("(s.sample_id" + like + a + " ESCAPE '\\' OR s.description" + like + b +
              " ESCAPE '\\' OR EXISTS (SELECT 1 FROM scan_tags t WHERE t.scan_id = s.id AND t.tag" +
              like + c + " ESCAPE '\\'))");
  }
  if (query.sample_id) condition("s.sample_id = " + bind(*query.sample_id));
  if (query.tag)
    condition("EXISTS (SELECT 1 FROM scan_tags t WHERE t.scan_id = s.id AND t.tag = " +
              bind(*query.tag) + ")");
  if (query.rig) condition("s.rig = " + bind(*query.rig));
  if (query.from) condition("s.created >= " + bind(*query.from));
  if (query.to) condition("s.created <= " + bind(*query.to));
  if (query.status) condition("s.status = " + bind(to_string(*query.status)));
  const auto number = [&](double value) { return dialect.number(bind(std::to_string(value))); };
  for (const auto& range : query.fabric) {
    // Column names from the fixed list in CatalogueQuery, never the user's text.
    if (range.min) condition("s." + range.column + " >= " + number(*range.min));
    if (range.max) condition("s." + range.column + " <= " + number(*range.max));
  }
  return f;
}

ReportFigures figures_of(const nlohmann::json& report) {
  using Pointer = nlohmann::json::json_pointer;
  return {number_at(report, Pointer("/ground_truth/angular_error_deg/mean")),
          number_at(report, Pointer("/residual/mean")), number_at(report, Pointer("/height/range")),
          number_at(report, Pointer("/timings_ms/total"))};
}

std::optional<fs::path> inside_root(const fs::path& root, const fs::path& path) {
  if (path.empty()) return std::nullopt;
  const fs::path absolute = (path.is_absolute() ? path : root / path).lexically_normal();
  const fs::path relative = absolute.lexically_relative(root);
  if (relative.empty() || relative == "." || *relative.begin() == "..") return std::nullopt;
  return absolute;
}

}  // namespace psrig::catalogue::rows
