// rig.toml's [catalogue] and the rig's identity in [daemon]: the embedded
// catalogue by default; a shared one puts each rig under its own prefix of
// the shared storage root; every mistake names its key and the fix.

#include <gtest/gtest.h>

#include "psrig/config/config_loader.h"

namespace psrig::config {
namespace {

RigConfig parse(const std::string& text) {
  auto config = parse_config(text, "/etc/psrig/rig.toml");
  EXPECT_TRUE(config) << config.error().describe();
  return config ? *config : RigConfig{};
}

Error error_of(const std::string& text, const std::string& key) {
  auto config = parse_config(text, "/etc/psrig/rig.toml");
  EXPECT_FALSE(config) << text;
  if (config) return {};
  EXPECT_EQ(config.error().kind, ErrorKind::bad_input);
  EXPECT_EQ(config.error().key, key) << config.error().describe();
  EXPECT_GT(config.error().line, 0) << config.error().describe();
  return config.error();
}

TEST(CatalogueConfig, TheDefaultIsTheEmbeddedCatalogueOfThisHost) {
  const RigConfig config = parse("[storage]\nroot = \"/srv/scans\"\n");
  EXPECT_FALSE(is_shared_catalogue(config.catalogue));
  EXPECT_EQ(config.daemon.rig_name, host_name());
  EXPECT_EQ(config.daemon.role, "rig");
  EXPECT_EQ(config.storage.root, "/srv/scans");
  EXPECT_EQ(config.storage.shared_root, "/srv/scans");
  EXPECT_TRUE(config.catalogue.journal.empty());
  EXPECT_EQ(config.daemon.public_url, "http://127.0.0.1:8470");
  EXPECT_FALSE(is_shared_catalogue(parse("[catalogue]\nurl = \"sqlite\"\n").catalogue));
}

TEST(CatalogueConfig, ASharedCatalogueGivesEachRigItsOwnPrefix) {
  const std::string shared =
      "[storage]\nroot = \"/mnt/lab-scans\"\n[daemon]\nrig_name = \"rig-1\"\n"
      "[catalogue]\nurl = \"postgresql://psrig@db.lab/psrig\"\n";
  RigConfig config = parse(shared);
  EXPECT_TRUE(is_shared_catalogue(config.catalogue));
  EXPECT_EQ(config.storage.shared_root, "/mnt/lab-scans");
  EXPECT_EQ(config.storage.root, "/mnt/lab-scans/rig-1");
  EXPECT_EQ(config.catalogue.journal, "/mnt/lab-scans/rig-1/catalogue-journal.json");
  config = parse(shared + "journal = \"journal.json\"\n");  // relative to the file
  EXPECT_EQ(config.catalogue.journal, "/etc/psrig/journal.json");
  EXPECT_TRUE(is_shared_catalogue(parse("[catalogue]\nurl = \"postgres://db/psrig\"\n").catalogue));
}

// A catalogue-only psrigd writes no scans: no prefix, no journal.
TEST(CatalogueConfig, ACatalogueOnlyPsrigdHasNoRigDirectoryNorJournal) {
  const RigConfig config =
      parse("[storage]\nroot = \"/mnt/lab-scans\"\n[daemon]\nrole = \"catalogue\"\n"
            "[catalogue]\nurl = \"postgresql://psrig@db.lab/psrig\"\n");
  EXPECT_EQ(config.storage.root, "/mnt/lab-scans");
  EXPECT_TRUE(config.catalogue.journal.empty());
}

TEST(CatalogueConfig, MistakesNameTheKeyAndTheFix) {
  auto e = error_of("[catalogue]\nurl = \"mysql://db/psrig\"\n", "catalogue.url");
  EXPECT_NE(e.message.find("postgresql://"), std::string::npos) << e.message;
  for (const char* name : {"../up", ".hidden", "a/b", "rig one", ""}) {
    e = error_of("[daemon]\nrig_name = \"" + std::string(name) + "\"\n", "daemon.rig_name");
    EXPECT_NE(e.message.find("rig-1"), std::string::npos) << e.message;
  }
  e = error_of("[daemon]\nrole = \"kiosk\"\n", "daemon.role");
  EXPECT_NE(e.message.find("\"catalogue\""), std::string::npos) << e.message;
  e = error_of("[daemon]\npublic_url = \"rig-1:8470\"\n", "daemon.public_url");
  EXPECT_NE(e.message.find("http://"), std::string::npos) << e.message;
}

TEST(CatalogueConfig, ThePublicUrlIsWhereOthersReachThisPsrigd) {
  EXPECT_EQ(parse("[daemon]\nport = 9000\n").daemon.public_url, "http://127.0.0.1:9000");
  EXPECT_EQ(parse("[daemon]\nlisten_address = \"0.0.0.0\"\ntoken = \"0123456789abcdef0\"\n")
                .daemon.public_url,
            "http://" + host_name() + ":8470");
  EXPECT_EQ(parse("[daemon]\nlisten_address = \"::1\"\n").daemon.public_url, "http://[::1]:8470");
  EXPECT_EQ(parse("[daemon]\npublic_url = \"https://rig-1.lab\"\n").daemon.public_url,
            "https://rig-1.lab");
}

}  // namespace
}  // namespace psrig::config
