// psrigd serves a scan's exports: made on the first request, kept in the
// scan directory, made once when asked for at once.

#include <cstdio>
#include <cstdlib>
#include <future>
#include <httplib.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "daemon_process.h"

namespace psrig::test {
namespace {

TEST(PsrigdExport, GlbAndU3maMadeOnceKeptAndServed) {
  TempDir temp;
  const int port = free_port();
  Daemon daemon(daemon_config(temp, port), port, temp / "psrigd.log");
  ASSERT_TRUE(daemon.wait_ready()) << daemon.log();
  const auto id = daemon.submit({{"sample_id", "E-1"}});
  const auto entry = daemon.wait_finished(id);
  ASSERT_EQ(entry["status"], "done") << entry.dump(2) << daemon.log();
  const fs::path scan_dir = entry["scan_directory"].get<std::string>();
  const std::string route = "/v1/scans/" + std::to_string(id) + "/export/";

  // Two clients at once: one export made, the same bytes to both.
  const auto fetch = [&](const std::string& format) {
    httplib::Client client("127.0.0.1", port);
    client.set_read_timeout(60, 0);
    auto res = client.Get(route + format);
    return res ? std::pair{res->status, res->body} : std::pair{-1, std::string()};
  };
  auto a = std::async(std::launch::async, fetch, "glb");
  auto b = std::async(std::launch::async, fetch, "glb");
  const auto [status_a, body_a] = a.get();
  const auto [status_b, body_b] = b.get();
  ASSERT_EQ(status_a, 200) << body_a << daemon.log();
  ASSERT_EQ(status_b, 200) << body_b;
  EXPECT_EQ(body_a, body_b);
  EXPECT_EQ(body_a.substr(0, 4), "glTF");
  const fs::path kept = scan_dir / "exports" / "material.glb";
  ASSERT_TRUE(fs::exists(kept));
  EXPECT_EQ(file_contents(kept), body_a);
  const auto made = fs::last_write_time(kept);
  // Kept: a later request serves the same file, not a new one.
  EXPECT_EQ(fetch("glb").second, body_a);
  EXPECT_EQ(fs::last_write_time(kept), made);

  // What psrigd serves passes the Khronos glTF-Validator as psrig export's does.
  const fs::path tools = fs::path(PSRIG_SOURCE_DIR) / "tools" / "node";
  if (std::system("node --version > /dev/null 2>&1") == 0 && fs::exists(tools / "node_modules")) {
    std::FILE* pipe = ::popen(
        ("node " + (tools / "validate-gltf.mjs").string() + " '" + kept.string() + "'").c_str(),
        "r");
    ASSERT_NE(pipe, nullptr);
    std::string out;
    char buffer[4096];
    while (std::size_t n = std::fread(buffer, 1, sizeof buffer, pipe))
      out.append(buffer, n);
    ::pclose(pipe);
    const auto report = nlohmann::json::parse(out, nullptr, false);
    ASSERT_TRUE(report.is_object() && report.contains("issues")) << out;
    EXPECT_EQ(report["issues"]["numErrors"], 0) << out;
    EXPECT_EQ(report["issues"]["numWarnings"], 0) << out;
  } else {
    std::printf(
        "glTF-Validator not run: node or tools/node/node_modules missing "
        "(scripts/install-deps installs them)\n");
  }

  const auto [u3ma_status, u3ma] = fetch("u3ma");
  ASSERT_EQ(u3ma_status, 200) << u3ma;
  EXPECT_EQ(u3ma.substr(0, 4), std::string("PK\x03\x04", 4));
  EXPECT_TRUE(fs::exists(scan_dir / "exports" / "material.u3ma"));

  EXPECT_NE(daemon.get(route + "fbx", 404).value("error", "").find("glb"), std::string::npos);
  EXPECT_EQ(daemon.get("/v1/scans/999/export/glb", 404).value("error", ""), "no scan 999");
}

}  // namespace
}  // namespace psrig::test
