#pragma once
// The TOML mechanism every section reader shares: a Section reads one
// table, each get() consuming a key and checking its type and range, so
// that errors name the file, line, column and key; finish() warns of keys
// left over, with the nearest known one. Private to config/.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <toml++/toml.h>
#include <vector>

#include "psrig/base/error.h"

namespace psrig::config {

namespace fs = std::filesystem;

// A TOML integer's value; nothing for any other node. (toml++'s value<int64_t>()
// also converts a float, which is undefined behaviour past 2^63.)
inline std::optional<std::int64_t> integer_of(const toml::node& n) {
  if (const auto* integer = n.as_integer()) return integer->get();
  return std::nullopt;
}

namespace fs = std::filesystem;

// Levenshtein distance, for "did you mean" on unknown keys.
inline std::size_t distance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j)
    row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t previous = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t substitution = previous + (a[i - 1] == b[j - 1] ? 0 : 1);
      previous = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, substitution});
    }
  }
  return row[b.size()];
}

// Reads one TOML table against what psrig knows of it: each get() consumes
// a key; finish() reports the keys left over as warnings.
class Section {
 public:
  Section(const toml::table* table, std::string path, const fs::path& file,
          std::vector<std::string>* warnings)
      : table_(table), path_(std::move(path)), file_(file), warnings_(warnings) {}

  [[nodiscard]] std::string key(const std::string& name) const {
    return path_.empty() ? name : path_ + "." + name;
  }

  Error error_at(const toml::node* node, const std::string& name,
                 const std::string& message) const {
    Error e = bad_input(file_, key(name), message);
    if (node) {
      e.line = static_cast<int>(node->source().begin.line);
      e.column = static_cast<int>(node->source().begin.column);
    }
    return e;
  }

  const toml::node* node(const std::string& name) {
    known_.insert(name);
    return table_ ? table_->get(name) : nullptr;
  }

  Status get(const std::string& name, double& out, double min, double max,
             bool exclusive_min = false) {
    const toml::node* n = node(name);
    if (!n) return {};
    const auto value = n->value<double>();  // integers convert too
    if (!value) return std::unexpected(error_at(n, name, "expected a number"));
    if (*value < min || *value > max || (exclusive_min && *value == min))
      return std::unexpected(
          error_at(n, name,
                   "is " + format(*value) + "; expected " +
                       (exclusive_min ? "more than " : "from ") + format(min) +
                       (max < 1e300 ? (exclusive_min ? ", at most " : " to ") + format(max) : "")));
    out = *value;
    return {};
  }

  Status get(const std::string& name, int& out, long min, long max) {
    const toml::node* n = node(name);
    if (!n) return {};
    const auto value = integer_of(*n);
    if (!value) return std::unexpected(error_at(n, name, "expected a whole number"));
    if (*value < min || *value > max)
      return std::unexpected(error_at(n, name,
                                      "is " + std::to_string(*value) + "; expected " +
                                          std::to_string(min) + " to " + std::to_string(max)));
    out = static_cast<int>(*value);
    return {};
  }

  Status get(const std::string& name, std::uint64_t& out) {
    const toml::node* n = node(name);
    if (!n) return {};
    const auto value = integer_of(*n);
    if (!value || *value < 0)
      return std::unexpected(error_at(n, name, "expected a whole number, 0 or more"));
    out = static_cast<std::uint64_t>(*value);
    return {};
  }

  Status get(const std::string& name, bool& out) {
    const toml::node* n = node(name);
    if (!n) return {};
    if (!n->is_boolean()) return std::unexpected(error_at(n, name, "expected true or false"));
    out = *n->value<bool>();
    return {};
  }

  Status get(const std::string& name, std::string& out,
             std::initializer_list<const char*> allowed = {}) {
    const toml::node* n = node(name);
    if (!n) return {};
    if (!n->is_string()) return std::unexpected(error_at(n, name, "expected a string"));
    const std::string value = *n->value<std::string>();
    if (allowed.size() > 0 &&
        std::none_of(allowed.begin(), allowed.end(), [&](const char* a) { return value == a; })) {
      std::string list;
      for (const char* a : allowed)
        list += (list.empty() ? "\"" : ", \"") + std::string(a) + "\"";
      return std::unexpected(error_at(n, name, "is \"" + value + "\"; expected one of " + list));
    }
    out = value;
    return {};
  }

  Status get(const std::string& name, std::vector<double>& out, double min, double max) {
    const toml::node* n = node(name);
    if (!n) return {};
    const toml::array* array = n->as_array();
    if (!array) return std::unexpected(error_at(n, name, "expected an array of numbers"));
    std::vector<double> values;
    for (const auto& element : *array) {
      const auto value = element.value<double>();
      if (!value) return std::unexpected(error_at(&element, name, "expected an array of numbers"));
      if (*value < min || *value > max)
        return std::unexpected(error_at(&element, name,
                                        "has " + format(*value) + "; expected values from " +
                                            format(min) + " to " + format(max)));
      values.push_back(*value);
    }
    out = std::move(values);
    return {};
  }

  // An array of [x, y, z] triples, each coordinate within [min, max] and z above z_min.
  Status get(const std::string& name, std::vector<std::array<double, 3>>& out, double limit,
             double z_min) {
    const toml::node* n = node(name);
    if (!n) return {};
    const toml::array* array = n->as_array();
    if (!array) return std::unexpected(error_at(n, name, "expected an array of [x, y, z] arrays"));
    std::vector<std::array<double, 3>> values;
    for (const auto& element : *array) {
      const toml::array* triple = element.as_array();
      if (!triple || triple->size() != 3)
        return std::unexpected(error_at(&element, name, "expected [x, y, z] in millimetres"));
      std::array<double, 3> v{};
      for (std::size_t i = 0; i < 3; ++i) {
        const auto value = (*triple)[i].value<double>();
        if (!value || !std::isfinite(*value) || std::abs(*value) > limit)
          return std::unexpected(error_at(
              &element, name, "expected [x, y, z] with numbers within ±" + format(limit) + " mm"));
        v[i] = *value;
      }
      if (v[2] <= z_min)
        return std::unexpected(error_at(
            &element, name,
            "has z = " + format(v[2]) + "; an LED must be above the swatch plane (z > 0)"));
      values.push_back(v);
    }
    out = std::move(values);
    return {};
  }

  Status get(const std::string& name, std::vector<unsigned>& out) {
    const toml::node* n = node(name);
    if (!n) return {};
    const toml::array* array = n->as_array();
    if (!array) return std::unexpected(error_at(n, name, "expected an array of whole numbers"));
    std::vector<unsigned> values;
    for (const auto& element : *array) {
      const auto value = integer_of(element);
      if (!value || *value < 0 || *value > std::numeric_limits<unsigned>::max())
        return std::unexpected(error_at(&element, name,
                                        "expected whole numbers, 0 to " +
                                            std::to_string(std::numeric_limits<unsigned>::max())));
      values.push_back(static_cast<unsigned>(*value));
    }
    out = std::move(values);
    return {};
  }

  Status get(const std::string& name, std::vector<std::string>& out) {
    const toml::node* n = node(name);
    if (!n) return {};
    const toml::array* array = n->as_array();
    if (!array) return std::unexpected(error_at(n, name, "expected an array of strings"));
    std::vector<std::string> values;
    for (const auto& element : *array) {
      if (!element.is_string())
        return std::unexpected(error_at(&element, name, "expected an array of strings"));
      values.push_back(*element.value<std::string>());
    }
    out = std::move(values);
    return {};
  }

  // A warning about `name` (at its line when present), as finish() words them.
  void warn(const std::string& name, const std::string& message) const {
    if (!warnings_) return;
    std::ostringstream line;
    line << file_.string();
    if (const toml::node* n = find(name))
      line << ":" << n->source().begin.line << ":" << n->source().begin.column;
    line << ": " << key(name) << ": " << message;
    warnings_->push_back(line.str());
  }

  // A sub-table, or nullptr when absent; an error when `name` is not a table.
  Result<const toml::table*> table(const std::string& name) {
    const toml::node* n = node(name);
    if (!n) return nullptr;
    if (!n->is_table())
      return std::unexpected(error_at(n, name, "expected a table ([" + key(name) + "])"));
    return n->as_table();
  }

  void finish() const {
    if (!table_ || !warnings_) return;
    for (const auto& [name, value] : *table_) {
      const std::string k(name.str());
      if (known_.contains(k)) continue;
      std::string nearest;
      std::size_t best = 3;  // only suggest close spellings
      for (const auto& known : known_)
        if (const std::size_t d = distance(k, known); d < best) best = d, nearest = known;
      std::ostringstream line;
      line << file_.string() << ":" << name.source().begin.line << ":" << name.source().begin.column
           << ": " << key(k) << ": unknown key, ignored"
           << (nearest.empty() ? "" : " (did you mean '" + key(nearest) + "'?)");
      warnings_->push_back(line.str());
    }
  }

  // The sub-table `name` as a Section of its own (empty when absent).
  Result<Section> sub(const std::string& name) {
    auto t = table(name);
    if (!t) return std::unexpected(t.error());
    return Section(*t, key(name), file_, warnings_);
  }

  // The configuration file: relative paths in it resolve against its folder.
  [[nodiscard]] const fs::path& file() const { return file_; }

  [[nodiscard]] const toml::node* find(const std::string& name) const {
    return table_ ? table_->get(name) : nullptr;
  }

 private:
  static std::string format(double value) {
    std::ostringstream s;
    s << value;
    return s.str();
  }

  const toml::table* table_;
  std::string path_;
  fs::path file_;
  std::vector<std::string>* warnings_;
  std::set<std::string> known_;
};

#define PSRIG_TRY(expression)                                                           \
  do {                                                                                  \
    if (auto status_ = (expression); !status_) return std::unexpected(status_.error()); \
  } while (false)

inline constexpr double kNoMax = 1e308;

// A path the file gives: absolute as written, relative to the file's folder.
inline fs::path relative_to_file(const fs::path& file, const std::string& text) {
  return fs::path(text).is_absolute() ? fs::path(text)
                                      : (file.parent_path() / text).lexically_normal();
}

}  // namespace psrig::config
