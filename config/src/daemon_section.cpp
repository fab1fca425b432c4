// rig.toml's [daemon] and [catalogue]: psrigd's addresses, token, PLC, rig
// name, and where its catalogue lives.

#include <arpa/inet.h>
#include <string>
#include <utility>

#include "section_readers.h"
#include "toml_section.h"

namespace psrig::config {

// Why `name` cannot name a rig (it becomes a directory under the shared
// storage root), or nothing.
std::optional<std::string> rig_name_problem(const std::string& name) {
  if (name.empty()) return "is empty";
  if (name.size() > 64) return "is longer than 64 characters";
  if (name.front() == '.') return "begins with '.'";
  for (const char ch : name)
    if (!std::isalnum(static_cast<unsigned char>(ch)) && ch != '.' && ch != '-' && ch != '_')
      return std::string("holds '") + ch + "'";
  return std::nullopt;
}

Status read_daemon(Section& daemon, RigConfig& c) {
  const fs::path& section_file = daemon.file();
  auto& d = c.daemon;
  PSRIG_TRY(daemon.get("listen_address", d.listen_address));
  PSRIG_TRY(daemon.get("port", d.port, 1, 65535));
  PSRIG_TRY(daemon.get("token", d.token));
  PSRIG_TRY(daemon.get("queue_limit", d.queue_limit, 1, 10000));
  PSRIG_TRY(daemon.get("modbus_address", d.modbus_address));
  PSRIG_TRY(daemon.get("modbus_port", d.modbus_port, 0, 65535));
  PSRIG_TRY(daemon.get("modbus_allow", d.modbus_allow));
  std::string web_root;
  PSRIG_TRY(daemon.get("web_root", web_root));
  PSRIG_TRY(daemon.get("rig_name", d.rig_name));
  PSRIG_TRY(daemon.get("role", d.role, {"rig", "catalogue"}));
  PSRIG_TRY(daemon.get("public_url", d.public_url));
  daemon.finish();
  if (!daemon.find("rig_name")) d.rig_name = host_name();
  if (auto problem = rig_name_problem(d.rig_name))
    return std::unexpected(daemon.error_at(
        daemon.find("rig_name"), "rig_name",
        (daemon.find("rig_name") ? "\"" + d.rig_name + "\" "
                                 : "the hostname \"" + d.rig_name + "\" ") +
            *problem + "; set rig_name to letters, digits, '.', '-' or '_' (e.g. \"rig-1\")"));
  if (d.public_url.empty()) {
    const bool everywhere = d.listen_address == "0.0.0.0" || d.listen_address == "::";
    std::string host = everywhere ? host_name() : d.listen_address;
    if (host.find(':') != std::string::npos) host = "[" + host + "]";
    d.public_url = "http://" + host + ":" + std::to_string(d.port);
  } else if (!d.public_url.starts_with("http://") && !d.public_url.starts_with("https://")) {
    return std::unexpected(daemon.error_at(
        daemon.find("public_url"), "public_url",
        "\"" + d.public_url +
            "\" is not an http:// or https:// URL; give the address other psrigd reach this "
            "one's API at, e.g. \"http://rig-1.lab:8470\""));
  }
  if (!web_root.empty()) {
    d.web_root = relative_to_file(section_file, web_root);
    if (!std::filesystem::is_regular_file(d.web_root / "index.html"))
      return std::unexpected(daemon.error_at(
          daemon.find("web_root"), "web_root",
          "\"" + d.web_root.string() +
              "\" holds no index.html; build the catalogue (scripts/build) and point web_root "
              "at its output (build/web), or leave web_root out"));
  }
  for (std::size_t i = 0; i < d.modbus_allow.size(); ++i) {
    in_addr parsed{};
    if (::inet_pton(AF_INET, d.modbus_allow[i].c_str(), &parsed) != 1)
      return std::unexpected(
          daemon.error_at(daemon.find("modbus_allow")->as_array()->get(i), "modbus_allow",
                          "\"" + d.modbus_allow[i] +
                              "\" is not an IPv4 address; list the PLCs that may connect, e.g. "
                              "[\"192.0.2.10\"]"));
  }
  for (const auto& [key, value] :
       {std::pair<const char*, const std::string&>{"listen_address", d.listen_address},
        {"modbus_address", d.modbus_address}})
    if (value.empty())
      return std::unexpected(daemon.error_at(daemon.find(key), key,
                                             "is empty; give an address such as \"127.0.0.1\""));
  // Anyone who can reach the port could drive the rig: off this machine,
  // only with a token worth guessing.
  constexpr std::size_t kMinTokenLength = 16;
  if (!d.token.empty() && d.token.size() < kMinTokenLength)
    return std::unexpected(daemon.error_at(
        daemon.find("token"), "token",
        "is " + std::to_string(d.token.size()) + " characters; use " +
            std::to_string(kMinTokenLength) + " or more (e.g. `openssl rand -hex 24`)"));
  if (d.token.empty() && !is_loopback_address(d.listen_address))
    return std::unexpected(daemon.error_at(
        daemon.find("listen_address"), "listen_address",
        "is \"" + d.listen_address +
            "\", reachable from other machines, but daemon.token is not set; set a token "
            "(e.g. `openssl rand -hex 24`) or listen on 127.0.0.1"));
  // The Modbus server has no authentication: whoever reaches it can
  // trigger scans and turn the lights off.
  if (d.modbus_port != 0 && d.modbus_allow.empty() && !is_loopback_address(d.modbus_address))
    daemon.warn("modbus_address",
                "is \"" + d.modbus_address +
                    "\", reachable from other machines, and daemon.modbus_allow is empty: "
                    "anyone who can reach port " +
                    std::to_string(d.modbus_port) +
                    " can trigger scans and turn the lights off (Modbus has no "
                    "authentication); list the PLC in daemon.modbus_allow (e.g. "
                    "modbus_allow = [\"192.0.2.10\"]) or listen on 127.0.0.1");
  return {};
}

Status read_catalogue(Section& catalogue, RigConfig& c) {
  const fs::path& section_file = catalogue.file();
  auto& d = c.daemon;
  PSRIG_TRY(catalogue.get("url", c.catalogue.url));
  std::string journal;
  PSRIG_TRY(catalogue.get("journal", journal));
  catalogue.finish();
  if (!c.catalogue.url.empty() && c.catalogue.url != "sqlite" && !is_shared_catalogue(c.catalogue))
    return std::unexpected(catalogue.error_at(
        catalogue.find("url"), "url",
        "\"" + c.catalogue.url +
            "\" is neither \"sqlite\" (the embedded catalogue, the default) nor a PostgreSQL "
            "URL; give e.g. \"postgresql://psrig@db.lab/psrig\" or leave url out"));
  // Each rig of a shared catalogue writes under its own prefix of the
  // shared storage root; a catalogue-only psrigd writes no scans.
  c.storage.shared_root = c.storage.root;
  if (is_shared_catalogue(c.catalogue) && d.role == "rig")
    c.storage.root = c.storage.shared_root / d.rig_name;
  if (!journal.empty())
    c.catalogue.journal = relative_to_file(section_file, journal);
  else if (is_shared_catalogue(c.catalogue) && d.role == "rig")
    c.catalogue.journal = c.storage.root / "catalogue-journal.json";
  return {};
}

}  // namespace psrig::config
