#include "emulated_gpio_chip.h"

#include <cerrno>
#include <cstring>
#include <fcntl.h>
#include <filesystem>
#include <fstream>
#include <sys/stat.h>
#include <unistd.h>

// How a line handle gets a file descriptor. In the kernel,
// GPIO_GET_LINEHANDLE_IOCTL creates an anonymous-inode fd and returns its
// number in the request; ioctls on that fd then address the handle. Under
// umockdev the ioctl is answered by a handler, and only descriptors that the
// preload library saw being opened on an emulated /dev node reach a handler.
// The handler runs in the same process as the code under test (on the
// testbed's GLib thread), so it can open such a node itself: the descriptor
// it gets is just as valid for the code under test, which receives its
// number in the request. Each handle gets a node of its own
// (/dev/.gpiolh/<chip>-<n>, a directory readdir-based chip scans skip), so
// its handler knows which handle an ioctl is for, whatever order the
// connections are served in. Returning the chip's own fd instead would
// route the handle's ioctls to the chip, but libgpiod closes the handle fd
// on release, which would close the chip under it.
//
// Closing: the kernel frees a handle's lines when its fd is closed. umockdev
// tells us nothing synchronously, so before every request the chip checks
// whether each handle's descriptor still refers to that handle's node file
// (same device and inode; a reused number refers to something else).

namespace psrig::test {
namespace {

constexpr unsigned kGpioMajor = 254;

void copy_name(char (&to)[GPIO_MAX_NAME_SIZE], const std::string& from) {
  std::memset(to, 0, sizeof to);
  std::strncpy(to, from.c_str(), sizeof to - 1);
}

bool handle_fd_is_open(int fd, dev_t dev, ino_t ino) {
  struct stat st {};
  return ::fstat(fd, &st) == 0 && st.st_dev == dev && st.st_ino == ino;
}

}  // namespace

EmulatedGpioChip::EmulatedGpioChip(UmockdevBed& bed, Options options)
    : bed_(bed), options_(std::move(options)) {
  devnode_ = "/dev/" + options_.name;
  const std::string platform = "platform/gpio-sim." + std::to_string(options_.minor);
  syspath_ = "/sys/devices/" + platform + "/" + options_.name;
  lines_.resize(options_.lines, Line{options_.initial_level, {}, -1});
  history_.push_back(levels_locked());

  bed_.attach(devnode_, [this](UMockdevIoctlClient* client) { return on_chip_ioctl(client); });
  // What libgpiod checks: the node is a character device whose major:minor
  // match /sys/bus/gpio/devices/<name>/dev, newline and all (it drops the
  // last character read; "\\n" is umockdev's escape for it).
  bed_.add_from_string("P: /devices/" + platform + "/" + options_.name + "\nN: " + options_.name +
                       "\nE: SUBSYSTEM=gpio\nE: DEVNAME=" + devnode_ + "\nA: dev=" +
                       std::to_string(kGpioMajor) + ":" + std::to_string(options_.minor) + "\\n\n");
  bed_.add_bus_link("gpio", syspath_);
}

EmulatedGpioChip::~EmulatedGpioChip() {
  std::vector<std::string> nodes{devnode_};
  {
    std::lock_guard lock(mutex_);
    for (const auto& handle : handles_)
      nodes.push_back(handle.devnode);
  }
  for (const auto& node : nodes)
    bed_.detach(node);
}

void EmulatedGpioChip::set_listener(Listener listener) {
  std::lock_guard lock(mutex_);
  listener_ = std::move(listener);
}

void EmulatedGpioChip::hold(unsigned offset, const std::string& consumer) {
  std::lock_guard lock(mutex_);
  lines_.at(offset).held_by = consumer;
}

void EmulatedGpioChip::fail_sets(int count, int error) {
  std::lock_guard lock(mutex_);
  fail_count_ = count;
  fail_error_ = error;
}

void EmulatedGpioChip::vanish_after(int sets) {
  std::lock_guard lock(mutex_);
  if (sets <= 0)
    vanish_locked();
  else
    vanish_after_ = sets;
}

bool EmulatedGpioChip::vanished() const {
  std::lock_guard lock(mutex_);
  return vanished_;
}

std::vector<int> EmulatedGpioChip::levels() const {
  std::lock_guard lock(mutex_);
  return levels_locked();
}

std::vector<int> EmulatedGpioChip::levels_locked() const {
  std::vector<int> levels;
  for (const auto& line : lines_)
    levels.push_back(line.level);
  return levels;
}

std::vector<std::vector<int>> EmulatedGpioChip::history() const {
  std::lock_guard lock(mutex_);
  return history_;
}

std::set<unsigned> EmulatedGpioChip::requested() const {
  std::lock_guard lock(mutex_);
  std::set<unsigned> offsets;
  for (const auto& handle : handles_)
    if (handle.open && handle_fd_is_open(handle.fd, handle.node_dev, handle.node_ino))
      offsets.insert(handle.offsets.begin(), handle.offsets.end());
  return offsets;
}

std::string EmulatedGpioChip::consumer(unsigned offset) const {
  std::lock_guard lock(mutex_);
  const Line& line = lines_.at(offset);
  if (!line.held_by.empty()) return line.held_by;
  if (line.handle < 0) return {};
  const Handle& handle = handles_[line.handle];
  return handle_fd_is_open(handle.fd, handle.node_dev, handle.node_ino) ? handle.consumer
                                                                        : std::string{};
}

std::uint32_t EmulatedGpioChip::request_flags(unsigned offset) const {
  std::lock_guard lock(mutex_);
  const Line& line = lines_.at(offset);
  if (line.handle < 0) return 0;
  const Handle& handle = handles_[line.handle];
  return handle_fd_is_open(handle.fd, handle.node_dev, handle.node_ino) ? handle.flags : 0;
}

std::set<unsigned long> EmulatedGpioChip::requests_seen() const {
  std::lock_guard lock(mutex_);
  return requests_seen_;
}

void EmulatedGpioChip::release_closed_handles() {
  for (std::size_t i = 0; i < handles_.size(); ++i) {
    Handle& handle = handles_[i];
    if (!handle.open || handle_fd_is_open(handle.fd, handle.node_dev, handle.node_ino)) continue;
    handle.open = false;
    // Released lines keep their level, as most GPIO drivers do.
    for (unsigned offset : handle.offsets)
      if (lines_[offset].handle == static_cast<int>(i)) lines_[offset].handle = -1;
  }
}

void EmulatedGpioChip::change(const std::vector<int>& after) {
  const std::vector<int> before = levels_locked();
  for (std::size_t i = 0; i < lines_.size(); ++i)
    lines_[i].level = after[i];
  history_.push_back(after);
  if (listener_) listener_(before, after);
}

void EmulatedGpioChip::vanish_locked() {
  if (vanished_) return;
  vanished_ = true;
  vanish_after_ = -1;
  bed_.remove_device(syspath_);
  // Whatever umockdev left behind of the chip goes too.
  namespace fs = std::filesystem;
  std::error_code ignored;
  fs::remove(fs::path(bed_.root()) / "sys/bus/gpio/devices" / options_.name, ignored);
  fs::remove(fs::path(bed_.root()) / ("." + devnode_), ignored);
}

bool EmulatedGpioChip::on_chip_ioctl(UMockdevIoctlClient* client) {
  std::lock_guard lock(mutex_);
  const unsigned long request = umockdev_ioctl_client_get_request(client);
  requests_seen_.insert(request);
  // The kernel answers ENODEV on descriptors of a chip that went away.
  if (vanished_) return answer(client, -1, ENODEV);
  release_closed_handles();
  switch (request) {
    case GPIO_GET_CHIPINFO_IOCTL:
      return get_chip_info(client);
    case GPIO_GET_LINEINFO_IOCTL:
      return get_line_info(client);
    case GPIO_GET_LINEHANDLE_IOCTL:
      return get_line_handle(client);
    default:
      return false;  // ENOTTY, as for any ioctl the chip does not know
  }
}

bool EmulatedGpioChip::on_handle_ioctl(int index, UMockdevIoctlClient* client) {
  std::lock_guard lock(mutex_);
  const unsigned long request = umockdev_ioctl_client_get_request(client);
  requests_seen_.insert(request);
  if (vanished_) return answer(client, -1, ENODEV);
  Handle& handle = handles_[index];
  switch (request) {
    case GPIOHANDLE_SET_LINE_VALUES_IOCTL:
      return set_values(handle, client);
    case GPIOHANDLE_GET_LINE_VALUES_IOCTL:
      return get_values(handle, client);
    default:
      return false;
  }
}

bool EmulatedGpioChip::get_chip_info(UMockdevIoctlClient* client) {
  Pointee<gpiochip_info> info(client);
  if (!info) return answer(client, -1, EFAULT);
  copy_name(info->name, options_.name);
  copy_name(info->label, options_.label);
  info->lines = options_.lines;
  return answer(client, 0);
}

bool EmulatedGpioChip::get_line_info(UMockdevIoctlClient* client) {
  Pointee<gpioline_info> info(client);
  if (!info) return answer(client, -1, EFAULT);
  const unsigned offset = info->line_offset;
  if (offset >= lines_.size()) return answer(client, -1, EINVAL);
  const Line& line = lines_[offset];
  info->flags = 0;
  std::string consumer;
  if (!line.held_by.empty()) {
    info->flags |= GPIOLINE_FLAG_KERNEL;
    consumer = line.held_by;
  } else if (line.handle >= 0) {
    const Handle& handle = handles_[line.handle];
    info->flags |= GPIOLINE_FLAG_KERNEL;
    if (handle.flags & GPIOHANDLE_REQUEST_OUTPUT) info->flags |= GPIOLINE_FLAG_IS_OUT;
    if (handle.flags & GPIOHANDLE_REQUEST_ACTIVE_LOW) info->flags |= GPIOLINE_FLAG_ACTIVE_LOW;
    consumer = handle.consumer;
  }
  copy_name(info->name, "");
  copy_name(info->consumer, consumer);
  return answer(client, 0);
}

bool EmulatedGpioChip::get_line_handle(UMockdevIoctlClient* client) {
  Pointee<gpiohandle_request> request(client);
  if (!request) return answer(client, -1, EFAULT);
  // The kernel's checks, in its order.
  const std::uint32_t flags = request->flags;
  constexpr std::uint32_t known = GPIOHANDLE_REQUEST_INPUT | GPIOHANDLE_REQUEST_OUTPUT |
                                  GPIOHANDLE_REQUEST_ACTIVE_LOW | GPIOHANDLE_REQUEST_OPEN_DRAIN |
                                  GPIOHANDLE_REQUEST_OPEN_SOURCE | GPIOHANDLE_REQUEST_BIAS_PULL_UP |
                                  GPIOHANDLE_REQUEST_BIAS_PULL_DOWN |
                                  GPIOHANDLE_REQUEST_BIAS_DISABLE;
  const bool output = flags & GPIOHANDLE_REQUEST_OUTPUT;
  if (request->lines == 0 || request->lines > GPIOHANDLES_MAX || (flags & ~known) ||
      (output && (flags & GPIOHANDLE_REQUEST_INPUT)) ||
      (!output && (flags & (GPIOHANDLE_REQUEST_OPEN_DRAIN | GPIOHANDLE_REQUEST_OPEN_SOURCE))))
    return answer(client, -1, EINVAL);
  Handle handle;
  handle.flags = flags;
  handle.consumer = std::string(request->consumer_label,
                                strnlen(request->consumer_label, sizeof request->consumer_label));
  if (handle.consumer.empty()) handle.consumer = "?";
  std::set<unsigned> seen;
  for (unsigned i = 0; i < request->lines; ++i) {
    const unsigned offset = request->lineoffsets[i];
    if (offset >= lines_.size()) return answer(client, -1, EINVAL);
    const Line& line = lines_[offset];
    if (!line.held_by.empty() || line.handle >= 0 || !seen.insert(offset).second)
      return answer(client, -1, EBUSY);
    handle.offsets.push_back(offset);
  }

  // The handle's own node, and a descriptor on it for the caller.
  const int index = static_cast<int>(handles_.size());
  handle.devnode = "/dev/.gpiolh/" + options_.name + "-" + std::to_string(index);
  try {
    namespace fs = std::filesystem;
    const fs::path file = fs::path(bed_.root()) / ("." + handle.devnode);
    fs::create_directories(file.parent_path());
    std::ofstream{file};
    bed_.attach(handle.devnode,
                [this, index](UMockdevIoctlClient* c) { return on_handle_ioctl(index, c); });
  } catch (const std::exception&) {
    return answer(client, -1, ENOMEM);
  }
  handle.fd = ::open(handle.devnode.c_str(), O_RDWR | O_CLOEXEC);
  if (handle.fd < 0) return answer(client, -1, errno);
  struct stat st {};
  if (::fstat(handle.fd, &st) != 0) return answer(client, -1, errno);
  handle.node_dev = st.st_dev;
  handle.node_ino = st.st_ino;
  handle.open = true;

  std::vector<int> after = levels_locked();
  const bool active_low = flags & GPIOHANDLE_REQUEST_ACTIVE_LOW;
  for (std::size_t i = 0; i < handle.offsets.size(); ++i) {
    lines_[handle.offsets[i]].handle = index;
    if (output) after[handle.offsets[i]] = (request->default_values[i] ? 1 : 0) ^ active_low;
  }
  request->fd = handle.fd;
  handles_.push_back(std::move(handle));
  change(after);
  return answer(client, 0);
}

bool EmulatedGpioChip::set_values(Handle& handle, UMockdevIoctlClient* client) {
  if (!(handle.flags & GPIOHANDLE_REQUEST_OUTPUT)) return answer(client, -1, EPERM);
  Pointee<gpiohandle_data> data(client);
  if (!data) return answer(client, -1, EFAULT);
  if (fail_count_ > 0) {
    --fail_count_;
    return answer(client, -1, fail_error_);
  }
  const bool active_low = handle.flags & GPIOHANDLE_REQUEST_ACTIVE_LOW;
  std::vector<int> after = levels_locked();
  for (std::size_t i = 0; i < handle.offsets.size(); ++i)
    after[handle.offsets[i]] = (data->values[i] ? 1 : 0) ^ active_low;
  change(after);
  answer(client, 0);
  if (vanish_after_ > 0 && --vanish_after_ == 0) vanish_locked();
  return true;
}

bool EmulatedGpioChip::get_values(Handle& handle, UMockdevIoctlClient* client) {
  Pointee<gpiohandle_data> data(client);
  if (!data) return answer(client, -1, EFAULT);
  const bool active_low = handle.flags & GPIOHANDLE_REQUEST_ACTIVE_LOW;
  std::memset(data->values, 0, sizeof data->values);
  for (std::size_t i = 0; i < handle.offsets.size(); ++i)
    data->values[i] = static_cast<__u8>(lines_[handle.offsets[i]].level ^ active_low);
  return answer(client, 0);
}

}  // namespace psrig::test
