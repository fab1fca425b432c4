// What psrigd gives the web catalogue: its pages without the token (the API
// still wants it), read-only and nothing outside their folder; the cards'
// thumbnail and relit view; text search and the total for paging.
#include <fstream>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "daemon_process.h"

namespace psrig::test {
namespace {

// A tiny catalogue build: index.html and one script.
fs::path fake_web_root(const TempDir& temp) {
  const fs::path root = temp / "web";
  fs::create_directories(root / "assets");
  std::ofstream(root / "index.html") << "<!doctype html><title>psrig</title>";
  std::ofstream(root / "assets" / "index-abc.js") << "console.log('psrig')";
  std::ofstream(temp / "secret.txt") << "not for the web";
  return root;
}

cv::Mat decode(const std::string& body) {
  return cv::imdecode(
      cv::Mat(1, static_cast<int>(body.size()), CV_8U, const_cast<char*>(body.data())),
      cv::IMREAD_UNCHANGED);
}

TEST(PsrigdWeb, PagesNeedNoTokenTheApiDoes) {
  TempDir temp;
  const int port = free_port();
  const fs::path root = fake_web_root(temp);
  Daemon daemon(daemon_config(temp, port,
                              {{"listen_address = \"127.0.0.1\"",
                                "listen_address = \"127.0.0.1\"\ntoken = \"" + kToken +
                                    "\"\nweb_root = \"" + root.string() + "\""}}),
                port, temp / "psrigd.log");
  ASSERT_TRUE(daemon.wait_ready()) << daemon.log();
  httplib::Client anonymous("127.0.0.1", port);
  auto index = anonymous.Get("/");
  ASSERT_TRUE(index);
  EXPECT_EQ(index->status, 200);
  EXPECT_EQ(index->get_header_value("Content-Type"), "text/html");
  EXPECT_NE(index->get_header_value("Content-Security-Policy").find("default-src 'self'"),
            std::string::npos);
  auto script = anonymous.Get("/assets/index-abc.js");
  ASSERT_TRUE(script);
  EXPECT_EQ(script->status, 200);
  EXPECT_EQ(script->get_header_value("Content-Type"), "text/javascript");
  EXPECT_NE(script->get_header_value("Cache-Control").find("immutable"), std::string::npos);
  // No listing, nothing outside the folder, no writing.
  for (const char* path :
       {"/assets/", "/../secret.txt", "/assets/../../secret.txt", "/%2e%2e/secret.txt"}) {
    auto res = anonymous.Get(path);
    ASSERT_TRUE(res) << path;
    EXPECT_NE(res->status, 200) << path;
    EXPECT_EQ(res->body.find("not for the web"), std::string::npos) << path;
  }
  auto put = anonymous.Post("/index.html", "x", "text/plain");
  ASSERT_TRUE(put);
  EXPECT_EQ(put->status, 401);  // not a page: the API's rules, the token first
  // The API still wants the token.
  auto status = anonymous.Get("/v1/status");
  ASSERT_TRUE(status);
  EXPECT_EQ(status->status, 401);
  EXPECT_EQ(daemon.http().Get("/v1/status")->status, 200);
}

TEST(PsrigdWeb, WithoutACatalogueTheRootSaysHowToBuildIt) {
  TempDir temp;
  const int port = free_port();
  Daemon daemon(daemon_config(temp, port), port, temp / "psrigd.log");
  ASSERT_TRUE(daemon.wait_ready()) << daemon.log();
  // psrigd in build/bin finds build/web when it is built; either way the
  // answer is a page or a JSON 404 that says what to do.
  auto res = daemon.http().Get("/");
  ASSERT_TRUE(res);
  if (res->status == 404)
    EXPECT_NE(res->body.find("scripts/build"), std::string::npos) << res->body;
  else
    EXPECT_EQ(res->status, 200);
}

TEST(PsrigdWeb, ThumbnailsRelitViewsTextSearchAndTotals) {
  TempDir temp;
  const int port = free_port();
  Daemon daemon(daemon_config(temp, port), port, temp / "psrigd.log");
  ASSERT_TRUE(daemon.wait_ready()) << daemon.log();
  const auto knit = daemon.submit(
      {{"sample_id", "JERSEY-12"}, {"description", "Navy cotton"}, {"tags", {"Knit"}}});
  const auto woven = daemon.submit({{"sample_id", "TWILL-3"}, {"description", "50% wool"}});
  ASSERT_EQ(daemon.wait_finished(knit)["status"], "done") << daemon.log();
  ASSERT_EQ(daemon.wait_finished(woven)["status"], "done") << daemon.log();

  const auto ids = [&](const std::string& query) {
    const auto answer = daemon.get("/v1/scans?" + query);
    std::vector<std::int64_t> found;
    for (const auto& scan : answer["scans"])
      found.push_back(scan["id"].get<std::int64_t>());
    return std::pair{found, answer["total"].get<std::int64_t>()};
  };
  EXPECT_EQ(ids("q=jersey"), std::pair(std::vector{knit}, std::int64_t{1}));  // any case
  EXPECT_EQ(ids("q=NAVY"), std::pair(std::vector{knit}, std::int64_t{1}));    // the description
  EXPECT_EQ(ids("q=knit"), std::pair(std::vector{knit}, std::int64_t{1}));    // a tag
  EXPECT_EQ(ids("q=50%25"), std::pair(std::vector{woven}, std::int64_t{1}));  // % is a character
  EXPECT_EQ(ids("q=5_%25"), std::pair(std::vector<std::int64_t>{}, std::int64_t{0}));
  EXPECT_EQ(ids("limit=1"), std::pair(std::vector{woven}, std::int64_t{2}));  // total: all pages
  EXPECT_EQ(ids("limit=1&offset=1"), std::pair(std::vector{knit}, std::int64_t{2}));

  const std::string base = "/v1/scans/" + std::to_string(knit);
  auto thumbnail = daemon.http().Get(base + "/thumbnail");
  auto relit = daemon.http().Get(base + "/relit");
  ASSERT_TRUE(thumbnail && relit);
  ASSERT_EQ(thumbnail->status, 200) << thumbnail->body;
  ASSERT_EQ(relit->status, 200) << relit->body;
  EXPECT_EQ(thumbnail->get_header_value("Content-Type"), "image/png");
  const cv::Mat albedo_small = decode(thumbnail->body);
  const cv::Mat lit = decode(relit->body);
  ASSERT_EQ(albedo_small.size(), cv::Size(320, 240));
  ASSERT_EQ(lit.size(), cv::Size(320, 240));
  // The relit view is the same swatch with the structure brought out:
  // more contrast than the albedo alone, and not a copy of it.
  cv::Scalar albedo_mean, albedo_sd, lit_mean, lit_sd;
  cv::meanStdDev(albedo_small, albedo_mean, albedo_sd);
  cv::meanStdDev(lit, lit_mean, lit_sd);
  EXPECT_GT(lit_sd[2], albedo_sd[2] * 1.2) << lit_sd << " vs " << albedo_sd;
  EXPECT_GT(cv::norm(lit, albedo_small, cv::NORM_L1) / lit.total(), 5.0);
  // Kept: the second answer is the same file; an ETag gets a 304.
  const fs::path maps = daemon.get(base)["maps_directory"].get<std::string>();
  EXPECT_TRUE(fs::exists(maps.parent_path() / "previews" / "relit.png"));
  auto again =
      daemon.http().Get(base + "/relit", {{"If-None-Match", relit->get_header_value("ETag")}});
  ASSERT_TRUE(again);
  EXPECT_EQ(again->status, 304);
  // A scan with no maps yet, and no scan: 404s that say so.
  auto missing = daemon.http().Get("/v1/scans/999/thumbnail");
  ASSERT_TRUE(missing);
  EXPECT_EQ(missing->status, 404);
  EXPECT_NE(missing->body.find("no scan 999"), std::string::npos);
}

}  // namespace
}  // namespace psrig::test
