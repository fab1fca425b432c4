#pragma once
// The HTTP API's answers, shared by its handlers (http_api.cpp,
// scan_exports.cpp): JSON replies, refusals, a scan id from the path, and a
// file streamed from disk.

#include <cstdint>
#include <filesystem>
#include <httplib.h>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

namespace psrig::daemon {

// JSON as text that never throws: a device's or driver's message may hold
// bytes that are not UTF-8, and nlohmann's dump() throws on them, which
// inside a streaming provider (outside httplib's try/catch) would end the
// daemon. Such bytes become U+FFFD.
[[nodiscard]] std::string to_text(const nlohmann::json& value);

void reply(httplib::Response& res, int status, const nlohmann::json& body);
// {"error": message}
void refuse(httplib::Response& res, int status, const std::string& message);

// A scan id as the path gives it: a positive whole number, nothing else.
[[nodiscard]] std::optional<std::int64_t> parse_id(const std::string& text);

// `path` as the answer, streamed, of `type`; 404 saying `missing` when it is
// not there. An ETag from its size and time, so a page that has it already
// gets a 304. With a `download_name`, a browser saves it under that name.
void send_file(const httplib::Request& req, httplib::Response& res,
               const std::filesystem::path& path, const std::string& type,
               const std::string& missing, const std::string& download_name = {});

}  // namespace psrig::daemon
