#pragma once
// The error a rig.toml's text gives, read as /etc/psrig/rig.toml: the
// test fails unless it is bad input naming that file, `key` and `line`.

#include <string>

#include <gtest/gtest.h>

#include "psrig/config/config_loader.h"

namespace psrig::config {

inline Error expect_error(const std::string& text, const std::string& key, int line) {
  auto config = parse_config(text, "/etc/psrig/rig.toml");
  EXPECT_FALSE(config) << text;
  if (config) return {};
  EXPECT_EQ(config.error().kind, ErrorKind::bad_input);
  EXPECT_EQ(config.error().key, key) << config.error().describe();
  EXPECT_EQ(config.error().line, line) << config.error().describe();
  EXPECT_EQ(config.error().file, std::filesystem::path("/etc/psrig/rig.toml"));
  return config.error();
}

}  // namespace psrig::config
