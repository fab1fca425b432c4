#pragma once
// Small helpers around a V4L2 file descriptor shared by the v4l2 backend's
// files: ioctl retried on EINTR, errors that name the device and the fix.

#include <cerrno>
#include <cstring>
#include <string>
#include <sys/ioctl.h>

#include "psrig/base/error.h"

namespace psrig::cameras::v4l2 {

// ioctl, retried when a signal interrupts it; -1 with errno set on failure.
inline int xioctl(int fd, unsigned long request, void* arg) {
  int r;
  do {
    r = ::ioctl(fd, request, arg);
  } while (r < 0 && errno == EINTR);
  return r;
}

inline std::string errno_text(int error) {
  return std::strerror(error);
}

// Another program holds the camera.
inline Error busy_error(const std::string& device, const std::string& step) {
  return io_error(device, step +
                              ": the camera is busy: another program is using it "
                              "(find it with `fuser " +
                              device + "`) and close that program");
}

// The device went away under us (unplugged, driver unbound, reset).
inline Error vanished_error(const std::string& device, const std::string& step) {
  return io_error(device, step +
                              ": the camera vanished (unplugged or reset): check its "
                              "cable and power, then find it again with `psrig "
                              "devices` or `v4l2-ctl --list-devices`");
}

// A failed ioctl: busy and vanished get their own words.
inline Error ioctl_error(const std::string& device, const std::string& step, int error) {
  if (error == EBUSY) return busy_error(device, step);
  if (error == ENODEV) return vanished_error(device, step);
  return io_error(device, step + " failed: " + errno_text(error));
}

}  // namespace psrig::cameras::v4l2
