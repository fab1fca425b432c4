#include "rig_forwarding.h"

#include <httplib.h>

#include "psrig/base/log.h"
#include "psrig/catalogue/rig_presence.h"

namespace psrig::daemon {

Result<catalogue::RigRecord> find_rig(const catalogue::Catalogue& catalogue,
                                      const std::string& name) {
  auto rigs = catalogue.rigs();
  if (!rigs) return std::unexpected(rigs.error());
  std::string known;
  for (const auto& rig : *rigs) {
    if (rig.name == name) return rig;
    known += (known.empty() ? "" : ", ") + rig.name;
  }
  return std::unexpected(bad_input(
      "", "rig",
      "no rig named \"" + name + "\" in the catalogue (" +
          (known.empty() ? std::string("none has announced itself") : "rigs: " + known) +
          "); a rig appears once its psrigd has started with this catalogue"));
}

Result<RigAnswer> forward_to_rig(const catalogue::RigRecord& rig, const std::string& method,
                                 const std::string& path, const std::string& body) {
  httplib::Client client(rig.api_url);
  if (!client.is_valid())
    return std::unexpected(bad_input("", "rig", "rig " + rig.name + "'s API URL \"" +
                                                    rig.api_url + "\" is not one psrigd can call"));
  client.set_connection_timeout(std::chrono::seconds(3));
  client.set_read_timeout(std::chrono::seconds(15));
  client.set_write_timeout(std::chrono::seconds(5));
  if (!rig.token.empty()) client.set_bearer_token_auth(rig.token.c_str());
  httplib::Result result =
      method == "DELETE" ? client.Delete(path.c_str())
                         : client.Post(path.c_str(), body.empty() ? "{}" : body, "application/json");
  if (!result)
    return std::unexpected(io_error("", "rig " + rig.name + " does not answer at " + rig.api_url +
                                            " (" + httplib::to_string(result.error()) +
                                            "); is its psrigd running?")
                               .with(ErrorCode::unavailable));
  logger("http")->info("{} {} forwarded to rig {} at {}: {}", method, path, rig.name, rig.api_url,
                       result->status);
  return RigAnswer{result->status, result->body};
}

nlohmann::json rigs_json(const std::vector<catalogue::RigRecord>& rigs,
                         const std::string& this_rig) {
  nlohmann::json list = nlohmann::json::array();
  for (const auto& rig : rigs)
    list.push_back({{"name", rig.name},
                    {"api_url", rig.api_url},
                    {"online", catalogue::rig_online(rig)},
                    {"last_seen", rig.last_seen},
                    {"seen_seconds_ago", rig.seen_seconds_ago},
                    {"this", rig.name == this_rig},
                    {"status", rig.status}});
  return {{"rigs", list}};
}

}  // namespace psrig::daemon
