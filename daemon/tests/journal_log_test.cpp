// psrigd's log lines as journald reads them from stderr: each starts with
// its syslog priority, "<3>" for an error (sd-daemon(3)).

#include <cstdlib>
#include <sstream>
#include <string>
#include <sys/stat.h>
#include <unistd.h>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <spdlog/sinks/ostream_sink.h>

#include "psrig/base/log.h"

namespace psrig::processing {
namespace {

using ::testing::HasSubstr;

TEST(JournalLogTest, FormatterPrefixesEachLevelWithItsPriority) {
  std::ostringstream out;
  auto sink = std::make_shared<spdlog::sinks::ostream_sink_mt>(out);
  sink->set_formatter(journal_formatter());
  spdlog::logger logger("daemon", sink);
  logger.set_level(spdlog::level::trace);
  logger.critical("disk gone");
  logger.error("scan 7 failed");
  logger.warn("queue full");
  logger.info("ready");
  logger.debug("frame 3");
  logger.trace("byte");
  EXPECT_EQ(out.str(),
            "<2>daemon: disk gone\n"
            "<3>daemon: scan 7 failed\n"
            "<4>daemon: queue full\n"
            "<6>daemon: ready\n"
            "<7>daemon: frame 3\n"
            "<7>daemon: byte\n");
}

// Turns the prefixes on for every logger of this process (ctest runs each test alone).
TEST(JournalLogTest, DaemonStderrCarriesThePrefixes) {
  ::testing::internal::CaptureStderr();
  log_to_stderr_for_journal();
  logger("plc-journal-test")->error("the LED driver stopped answering");
  logger("plc-journal-other")->warn("created after the switch");
  logger("plc-journal-test")->flush();
  const std::string err = ::testing::internal::GetCapturedStderr();
  EXPECT_THAT(err, HasSubstr("<3>plc-journal-test: the LED driver stopped answering\n"));
  EXPECT_THAT(err, HasSubstr("<4>plc-journal-other: created after the switch\n"));
}

TEST(JournalStreamTest, StderrIsTheJournalOnlyWhenJournalStreamNamesIt) {
  ::unsetenv("JOURNAL_STREAM");
  EXPECT_FALSE(stderr_is_journal());
  struct stat info {};
  ASSERT_EQ(::fstat(STDERR_FILENO, &info), 0);
  const std::string self = std::to_string(info.st_dev) + ":" + std::to_string(info.st_ino);
  ::setenv("JOURNAL_STREAM", self.c_str(), 1);
  EXPECT_TRUE(stderr_is_journal());
  // Inherited from a parent whose stderr was the journal; ours is not.
  ::setenv("JOURNAL_STREAM",
           (std::to_string(info.st_dev) + ":" + std::to_string(info.st_ino + 1)).c_str(), 1);
  EXPECT_FALSE(stderr_is_journal());
  ::setenv("JOURNAL_STREAM", "garbage", 1);
  EXPECT_FALSE(stderr_is_journal());
  ::unsetenv("JOURNAL_STREAM");
}

}  // namespace
}  // namespace psrig::processing
