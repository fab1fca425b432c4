// A preload library for the libcamera HIL tests: libcamera 0.0.3 opens its
// V4L2 nodes with syscall(SYS_openat, ...) (V4L2Device::open, so that its
// own V4L2 compatibility layer cannot catch it), which umockdev's preload
// library, wrapping open() and openat() but not syscall(), never sees: the
// node would be looked up on the real /dev and not found. This library
// wraps syscall() and sends SYS_openat through open64() (or openat() for a
// relative path under a directory descriptor), which reach umockdev's
// wrappers and so the testbed; umockdev's openat() redirects the path but
// does not set up its ioctl emulation, its open64() does. It adds
// O_NOCTTY: an emulated node may be a pseudo-terminal, which must not
// become the test's controlling terminal. Every other system call goes on
// unchanged.
//
// It also plays udevd's database: libudev (systemd 252) takes a device
// with a device number for initialised, and udev_enumerate's
// match_is_initialized (libcamera's enumerator asks for it) lists it, only
// if /run/udev/data/c<major>:<minor> exists, a path umockdev 0.17 does not
// redirect. Opening a path under /run/udev/ (open, openat, fopen and their
// 64-bit names) is sent to the same path under $UMOCKDEV_DIR, where the
// testbed writes those entries (UmockdevBed::add_udev_entry).
//
// It must come before umockdev's library in LD_PRELOAD: umockdev's wrappers
// call the C library's functions directly, never the next library's, so
// wrappers behind them are skipped. Its own wrappers call the next ones
// (umockdev's).
//
// psrig_hil_openat_shim_loaded() tells a test the library is there.

#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <dlfcn.h>
#include <fcntl.h>
#include <string>
#include <sys/syscall.h>
#include <unistd.h>

extern "C" {

int psrig_hil_openat_shim_loaded();

int psrig_hil_openat_shim_loaded() {
  return 1;
}

long syscall(long number, ...) noexcept {
  va_list args;
  va_start(args, number);
  long a[6];
  for (long& arg : a)
    arg = va_arg(args, long);
  va_end(args);

  // Through open64() where the directory does not matter: umockdev's
  // openat() redirects the path but does not set up ioctl emulation.
  const auto* path = reinterpret_cast<const char*>(a[1]);
  if (number == SYS_openat && path && (a[0] == AT_FDCWD || path[0] == '/'))
    return open64(path, static_cast<int>(a[2]) | O_NOCTTY, static_cast<mode_t>(a[3]));
  if (number == SYS_openat)
    return openat(static_cast<int>(a[0]), path, static_cast<int>(a[2]) | O_NOCTTY,
                  static_cast<mode_t>(a[3]));

  using Syscall = long (*)(long, ...);
  static const auto next = reinterpret_cast<Syscall>(dlsym(RTLD_NEXT, "syscall"));
  return next(number, a[0], a[1], a[2], a[3], a[4], a[5]);
}

namespace {

// `path` in the testbed when it is udev's database and a testbed is up.
std::string udev_database_path(const char* path) {
  const char* root = std::getenv("UMOCKDEV_DIR");
  if (!root || !path || std::strncmp(path, "/run/udev/", 10) != 0) return {};
  return std::string(root) + path;
}

}  // namespace

#define PSRIG_WRAP_OPEN(name)                                                 \
  int name(const char* path, int flags, ...) {                                \
    va_list args;                                                             \
    va_start(args, flags);                                                    \
    const auto mode = static_cast<mode_t>(va_arg(args, int));                 \
    va_end(args);                                                             \
    using Open = int (*)(const char*, int, ...);                              \
    static const auto next = reinterpret_cast<Open>(dlsym(RTLD_NEXT, #name)); \
    const std::string redirected = udev_database_path(path);                  \
    return next(redirected.empty() ? path : redirected.c_str(), flags, mode); \
  }
#define PSRIG_WRAP_OPENAT(name)                                                    \
  int name(int dir, const char* path, int flags, ...) {                            \
    va_list args;                                                                  \
    va_start(args, flags);                                                         \
    const auto mode = static_cast<mode_t>(va_arg(args, int));                      \
    va_end(args);                                                                  \
    using Openat = int (*)(int, const char*, int, ...);                            \
    static const auto next = reinterpret_cast<Openat>(dlsym(RTLD_NEXT, #name));    \
    const std::string redirected = udev_database_path(path);                       \
    return next(dir, redirected.empty() ? path : redirected.c_str(), flags, mode); \
  }

PSRIG_WRAP_OPEN(open)
PSRIG_WRAP_OPEN(open64)
PSRIG_WRAP_OPENAT(openat)
PSRIG_WRAP_OPENAT(openat64)

FILE* fopen(const char* path, const char* mode) {
  using Fopen = FILE* (*)(const char*, const char*);
  static const auto next = reinterpret_cast<Fopen>(dlsym(RTLD_NEXT, "fopen"));
  const std::string redirected = udev_database_path(path);
  return next(redirected.empty() ? path : redirected.c_str(), mode);
}

FILE* fopen64(const char* path, const char* mode) {
  using Fopen = FILE* (*)(const char*, const char*);
  static const auto next = reinterpret_cast<Fopen>(dlsym(RTLD_NEXT, "fopen64"));
  const std::string redirected = udev_database_path(path);
  return next(redirected.empty() ? path : redirected.c_str(), mode);
}

}  // extern "C"
