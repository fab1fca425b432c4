#include "http_answers.h"

#include <algorithm>
#include <array>
#include <charconv>
#include <fstream>
#include <memory>

#include "psrig/base/log.h"

namespace psrig::daemon {

namespace fs = std::filesystem;

std::string to_text(const nlohmann::json& value) {
  return value.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

void reply(httplib::Response& res, int status, const nlohmann::json& body) {
  res.status = status;
  res.set_content(to_text(body) + "\n", "application/json");
}

void refuse(httplib::Response& res, int status, const std::string& message) {
  reply(res, status, {{"error", message}});
}

std::optional<std::int64_t> parse_id(const std::string& text) {
  std::int64_t id = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), id);
  if (ec != std::errc() || end != text.data() + text.size() || id <= 0) return std::nullopt;
  return id;
}

void send_file(const httplib::Request& req, httplib::Response& res, const fs::path& path,
               const std::string& type, const std::string& missing,
               const std::string& download_name) {
  std::error_code ec;
  const auto size = fs::file_size(path, ec);
  if (ec || !fs::is_regular_file(path, ec)) return refuse(res, 404, missing);
  const auto time = fs::last_write_time(path, ec).time_since_epoch().count();
  const std::string etag = "\"" + std::to_string(size) + "-" + std::to_string(time) + "\"";
  res.set_header("ETag", etag);
  res.set_header("Cache-Control", "private, no-cache");
  if (req.get_header_value("If-None-Match") == etag) {
    res.status = 304;
    return;
  }
  auto stream = std::make_shared<std::ifstream>(path, std::ios::binary);
  if (!*stream) return refuse(res, 500, "cannot read " + path.filename().string());
  res.status = 200;
  if (!download_name.empty())
    res.set_header("Content-Disposition", "attachment; filename=\"" + download_name + "\"");
  res.set_content_provider(
      static_cast<std::size_t>(size), type,
      [stream](std::size_t offset, std::size_t length, httplib::DataSink& sink) {
        // httplib runs providers outside its exception handler: nothing may
        // escape, or the daemon ends. A failure ends this download only.
        try {
          std::array<char, 64 * 1024> buffer;
          stream->seekg(static_cast<std::streamoff>(offset));
          const auto chunk = std::min(length, buffer.size());
          stream->read(buffer.data(), static_cast<std::streamsize>(chunk));
          const auto got = static_cast<std::size_t>(stream->gcount());
          return got > 0 && sink.write(buffer.data(), got);
        } catch (const std::exception& e) {
          logger("http")->error("download: {}", e.what());
          return false;
        }
      });
}

}  // namespace psrig::daemon
