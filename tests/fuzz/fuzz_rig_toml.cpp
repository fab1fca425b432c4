// rig.toml, as config's loader takes it: the input is the text of a
// rig.toml given to parse_config() (toml++'s parser, then every section's
// schema and checks), with the unknown-key warnings collected. Every answer
// is fine except a crash, a sanitizer report, or an accepted configuration
// that breaks what the loader promises: one tilt per light channel.

#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>
#include <vector>

#include "fuzz_support.h"
#include "psrig/config/config_loader.h"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  psrig::fuzz::quiet_logs();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  std::vector<std::string> warnings;
  // Relative paths in it (storage.root) resolve against this file's folder;
  // nothing is read from or written there.
  auto config = psrig::config::parse_config(text, "/nonexistent/psrig-fuzz/rig.toml", &warnings);
  if (!config) {
    (void)config.error().describe();
    return 0;
  }
  if (config->geometry.tilts_deg.size() != static_cast<std::size_t>(config->lights.channels)) {
    std::fprintf(stderr, "fuzz_rig_toml: accepted %zu tilts for %d light channels\n",
                 config->geometry.tilts_deg.size(), static_cast<int>(config->lights.channels));
    std::abort();
  }
  return 0;
}
