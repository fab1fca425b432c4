#pragma once
// Requests for another rig, sent on to its psrigd: with a shared
// catalogue any psrigd (a catalogue-only one too) can start, cancel or
// delete a scan on any rig, through that rig's own daemon, which alone
// drives its lights and camera. The rig's address and token come from the
// catalogue's rigs list (RigPresence); its answer is returned as it came.

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "psrig/base/error.h"
#include "psrig/catalogue/catalogue.h"

namespace psrig::daemon {

struct RigAnswer {
  int status = 0;
  std::string body;
};

// The rig named `name` in the catalogue's rigs list; a bad_input error
// naming the rigs there are when it is not one.
[[nodiscard]] Result<catalogue::RigRecord> find_rig(const catalogue::Catalogue& catalogue,
                                                    const std::string& name);

// `method` `path` with `body` (JSON) to the rig's API, with its token. An
// error (ErrorCode::unavailable) naming the rig and its URL when it does
// not answer.
[[nodiscard]] Result<RigAnswer> forward_to_rig(const catalogue::RigRecord& rig,
                                               const std::string& method, const std::string& path,
                                               const std::string& body);

// GET /v1/rigs: every rig, its status, whether it is online, never its token.
[[nodiscard]] nlohmann::json rigs_json(const std::vector<catalogue::RigRecord>& rigs,
                                       const std::string& this_rig);

}  // namespace psrig::daemon
