#pragma once
// The web catalogue's pages (web/, built into build/web/), served by psrigd
// read-only from their folder: no directory listing, nothing outside it,
// and the API's token not needed for them (the page asks for it, then sends
// it to /v1/ only).

#include <filesystem>
#include <httplib.h>

#include "psrig/config/rig_config.h"

namespace psrig::daemon {

// daemon.web_root when set, else the first of <psrigd's folder>/../web (the
// build tree) and <psrigd's folder>/../share/psrig/web (installed) that
// holds an index.html; empty when none does.
[[nodiscard]] std::filesystem::path find_web_root(const config::DaemonConfig& daemon);

// Whether a request path is the API's (everything under /v1/), which the
// token guards, rather than one of the catalogue's pages.
[[nodiscard]] bool is_api_path(const std::string& path);

// Serves `root` at "/" with the MIME types the pages and glTF need, and
// headers that keep the pages from being framed or sniffed. With an empty
// root, GET / answers a JSON 404 saying how to build the catalogue.
void serve_web_catalogue(httplib::Server& server, const std::filesystem::path& root);

}  // namespace psrig::daemon
