#include "web_catalogue.h"

#include <array>
#include <system_error>
#include <unistd.h>

#include "psrig/base/log.h"

namespace psrig::daemon {

namespace fs = std::filesystem;

namespace {

fs::path own_folder() {
  std::error_code ec;
  const auto self = fs::read_symlink("/proc/self/exe", ec);
  return ec ? fs::path() : self.parent_path();
}

}  // namespace

fs::path find_web_root(const config::DaemonConfig& daemon) {
  if (!daemon.web_root.empty()) return daemon.web_root;  // checked by the loader
  const fs::path folder = own_folder();
  if (folder.empty()) return {};
  for (const auto& candidate : {folder / ".." / "web", folder / ".." / "share" / "psrig" / "web"}) {
    std::error_code ec;
    if (fs::is_regular_file(candidate / "index.html", ec))
      return fs::weakly_canonical(candidate, ec);
  }
  return {};
}

bool is_api_path(const std::string& path) {
  return path == "/v1" || path.starts_with("/v1/");
}

void serve_web_catalogue(httplib::Server& server, const fs::path& root) {
  if (root.empty()) {
    logger("http")->warn(
        "the web catalogue is not built: GET / answers 404 (build it with scripts/build, or set "
        "daemon.web_root)");
    server.Get("/", [](const httplib::Request&, httplib::Response& res) {
      res.status = 404;
      res.set_content(
          R"({"error": "the web catalogue is not installed here: build it (scripts/build) or set daemon.web_root; the API is under /v1/"})"
          "\n",
          "application/json");
    });
    return;
  }
  // httplib knows the common types; these it does not, or names otherwise.
  static constexpr std::array<std::pair<const char*, const char*>, 7> kTypes = {{
      {"js", "text/javascript"},
      {"mjs", "text/javascript"},
      {"gltf", "model/gltf+json"},
      {"glb", "model/gltf-binary"},
      {"webmanifest", "application/manifest+json"},
      {"map", "application/json"},
      {"woff2", "font/woff2"},
  }};
  for (const auto& [extension, type] : kTypes)
    server.set_file_extension_and_mimetype_mapping(extension, type);
  server.set_file_request_handler([](const httplib::Request& req, httplib::Response& res) {
    res.set_header("X-Content-Type-Options", "nosniff");
    res.set_header("X-Frame-Options", "DENY");
    res.set_header("Referrer-Policy", "no-referrer");
    // Everything the page loads comes from psrigd; textures and downloads
    // are blob: URLs of what the API answered.
    res.set_header("Content-Security-Policy",
                   "default-src 'self'; img-src 'self' blob: data:; connect-src 'self' blob:; "
                   "style-src 'self'; script-src 'self'; object-src 'none'; "
                   "frame-ancestors 'none'; base-uri 'self'");
    // Built files carry a content hash in their names: cache them for good;
    // index.html must be asked for again to find new ones.
    const bool hashed = req.path.starts_with("/assets/");
    res.set_header("Cache-Control", hashed ? "public, max-age=31536000, immutable" : "no-cache");
  });
  if (!server.set_mount_point("/", root.string()))
    logger("http")->error("cannot serve the web catalogue from {}", root.string());
  else
    logger("http")->info("web catalogue at / from {}", root.string());
}

}  // namespace psrig::daemon
