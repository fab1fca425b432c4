#pragma once
// psrig scan --remote URL: the scan queued on a running psrigd, followed
// until it is done; Ctrl-C cancels it there.

#include <string>
#include <vector>

namespace psrig::cli {

struct RemoteScan {
  std::string url;
  std::string token;  // empty: $PSRIG_TOKEN
  std::string sample_id;
  std::string description;
  std::vector<std::string> tags;
  bool quiet = false;
};

// The exit code: 0 done, 1 failed or aborted (or no daemon), 2 refused as
// bad input, 130 interrupted here.
int run_remote_scan(const RemoteScan& scan);

}  // namespace psrig::cli
