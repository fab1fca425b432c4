# Cross-compiling for arm64 (aarch64) Debian 12 from an x86-64 Debian 12
# (preset `arm64`, scripts/cross-build): Debian's cross compiler against a
# sysroot of Debian's own arm64 packages, the lines of
# scripts/debian-packages not marked host. A sysroot, not multiarch
# packages on this machine: libopencv-dev and libisal-dev are not
# Multi-Arch: same, so their :arm64 packages would remove the native ones.
# ctest runs the arm64 programs through qemu-aarch64 with that sysroot's
# libraries.
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)
set(CMAKE_LIBRARY_ARCHITECTURE aarch64-linux-gnu)
set(CMAKE_C_COMPILER aarch64-linux-gnu-gcc-12)
set(CMAKE_CXX_COMPILER aarch64-linux-gnu-g++-12)

# Beside the build, so that try_compile's projects find it too.
get_filename_component(CMAKE_SYSROOT "${CMAKE_CURRENT_LIST_DIR}/../build-arm64/sysroot" ABSOLUTE)
if(NOT EXISTS "${CMAKE_SYSROOT}/usr/include/opencv4")
  message(FATAL_ERROR "no arm64 sysroot at ${CMAKE_SYSROOT}: run scripts/cross-build arm64, which makes it")
endif()
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE ONLY)
set(ENV{PKG_CONFIG_SYSROOT_DIR} "${CMAKE_SYSROOT}")
set(ENV{PKG_CONFIG_LIBDIR} "${CMAKE_SYSROOT}/usr/lib/aarch64-linux-gnu/pkgconfig:${CMAKE_SYSROOT}/usr/share/pkgconfig")

set(CMAKE_CROSSCOMPILING_EMULATOR /usr/bin/qemu-aarch64-static -L "${CMAKE_SYSROOT}")
