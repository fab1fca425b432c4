// The test glue itself: an emulated device whose ioctls a handler answers.

#include "umockdev_bed.h"

#include <fcntl.h>
#include <sys/ioctl.h>
#include <unistd.h>

#include <gtest/gtest.h>

namespace psrig::test {
namespace {

TEST(UmockdevBed, HandlerAnswersIoctlsOfTheCodeUnderTest) {
  if (!UmockdevBed::available()) GTEST_SKIP() << "not under umockdev-wrapper";
  UmockdevBed bed;
  int calls = 0;
  bed.attach("/dev/psrigfake", [&](UMockdevIoctlClient* client) {
    ++calls;
    if (umockdev_ioctl_client_get_request(client) != 0x1234) return false;
    Pointee<int> value(client);
    *value *= 2;
    return answer(client, 7);
  });
  bed.add_from_string(
      "P: /devices/psrigfake\nN: psrigfake\nE: SUBSYSTEM=misc\nE: DEVNAME=/dev/psrigfake\nA: "
      "dev=10:200\n");
  const int fd = ::open("/dev/psrigfake", O_RDWR);
  ASSERT_GE(fd, 0) << std::strerror(errno);
  int value = 21;
  EXPECT_EQ(::ioctl(fd, 0x1234, &value), 7);
  EXPECT_EQ(value, 42);
  EXPECT_EQ(::ioctl(fd, 0x9999, &value), -1);
  EXPECT_EQ(errno, ENOTTY);
  ::close(fd);
  EXPECT_EQ(calls, 2);
}

}  // namespace
}  // namespace psrig::test
