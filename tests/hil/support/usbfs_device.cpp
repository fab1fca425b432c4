#include "usbfs_device.h"

#include <algorithm>
#include <cerrno>
#include <cstddef>
#include <cstdio>
#include <cstring>
#include <linux/usb/ch9.h>
#include <linux/usbdevice_fs.h>
#include <optional>
#include <sys/ioctl.h>  // _IOR and friends: usbdevice_fs.h uses them, includes none

namespace psrig::test {
namespace {

void put16(std::vector<std::uint8_t>& out, unsigned value) {
  out.push_back(static_cast<std::uint8_t>(value & 0xFF));
  out.push_back(static_cast<std::uint8_t>(value >> 8));
}

std::string hex(const std::vector<std::uint8_t>& bytes) {
  std::string text;
  char pair[3];
  for (std::uint8_t byte : bytes) {
    std::snprintf(pair, sizeof pair, "%02x", byte);
    text += pair;
  }
  return text;
}

}  // namespace

UsbfsDevice::UsbfsDevice(UmockdevBed& bed, Description description, OnOut on_out)
    : bed_(bed), description_(std::move(description)), on_out_(std::move(on_out)) {}

UsbfsDevice::~UsbfsDevice() {
  bed_.detach(devnode());
  if (plugged()) bed_.remove_device(syspath());
  for (Urb& urb : waiting_)
    release(urb);
  for (Urb& urb : ready_)
    release(urb);
}

std::string UsbfsDevice::devnode() const {
  char node[32];
  std::snprintf(node, sizeof node, "/dev/bus/usb/%03d/%03d", description_.busnum,
                description_.devnum);
  return node;
}

std::string UsbfsDevice::syspath() const {
  return "/sys/devices/psrig-usb/" + sysname();
}

std::string UsbfsDevice::sysname() const {
  return std::to_string(description_.busnum) + "-" + std::to_string(description_.port);
}

bool UsbfsDevice::plugged() const {
  const std::scoped_lock lock(mutex_);
  return plugged_;
}

int UsbfsDevice::halts_cleared(std::uint8_t endpoint) const {
  const std::scoped_lock lock(mutex_);
  const auto it = halts_cleared_.find(endpoint);
  return it == halts_cleared_.end() ? 0 : it->second;
}

int UsbfsDevice::interfaces_claimed() const {
  const std::scoped_lock lock(mutex_);
  return static_cast<int>(claims_.size());
}

std::vector<std::uint8_t> UsbfsDevice::descriptors() const {
  const Description& d = description_;
  std::vector<std::uint8_t> out = {18, USB_DT_DEVICE};
  put16(out, 0x0200);                    // bcdUSB
  out.insert(out.end(), {0, 0, 0, 64});  // class from the interface; ep0 64 bytes
  put16(out, d.vendor_id);
  put16(out, d.product_id);
  put16(out, d.bcd_device);
  out.push_back(d.manufacturer.empty() ? 0 : 1);
  out.push_back(d.product.empty() ? 0 : 2);
  out.push_back(d.serial.empty() ? 0 : 3);
  out.push_back(1);  // bNumConfigurations

  const auto endpoints = static_cast<unsigned>(d.endpoints.size());
  out.insert(out.end(), {9, USB_DT_CONFIG});
  put16(out, 9 + 9 + 7 * endpoints);                 // wTotalLength
  out.insert(out.end(), {1, 1, 0, 0x80, 50});        // one interface, value 1, bus powered 100 mA
  out.insert(out.end(), {9, USB_DT_INTERFACE, 0, 0,  // interface 0, alternate 0
                         static_cast<std::uint8_t>(endpoints), d.interface_class, 0, 0, 0});
  for (const Endpoint& e : d.endpoints) {
    out.insert(out.end(), {7, USB_DT_ENDPOINT, e.address, e.attributes});
    put16(out, e.max_packet);
    out.push_back(0);  // bInterval
  }
  return out;
}

std::vector<std::uint8_t> UsbfsDevice::string_descriptor(int index) const {
  if (index == 0) return {4, USB_DT_STRING, 0x09, 0x04};  // US English only
  const std::string* text = nullptr;
  if (index == 1 && !description_.manufacturer.empty()) text = &description_.manufacturer;
  if (index == 2 && !description_.product.empty()) text = &description_.product;
  if (index == 3 && !description_.serial.empty()) text = &description_.serial;
  if (!text) return {};
  std::vector<std::uint8_t> out = {static_cast<std::uint8_t>(2 + 2 * text->size()), USB_DT_STRING};
  for (char c : *text)
    put16(out, static_cast<unsigned char>(c));  // ASCII as UTF-16LE
  return out;
}

std::string UsbfsDevice::description_text() const {
  const Description& d = description_;
  char ids[64];
  std::snprintf(ids, sizeof ids, "%04x/%04x/%x", d.vendor_id, d.product_id, d.bcd_device);
  char number[8];
  std::string text = "P: " + syspath().substr(4) + "\n";  // without /sys
  text += "N: " + devnode().substr(5) + "\n";
  text += "E: SUBSYSTEM=usb\nE: DEVTYPE=usb_device\n";
  text += "E: DEVNAME=" + devnode().substr(5) + "\n";
  text += "E: PRODUCT=" + std::string(ids) + "\n";
  std::snprintf(number, sizeof number, "%03d", d.busnum);
  text += "E: BUSNUM=" + std::string(number) + "\n";
  std::snprintf(number, sizeof number, "%03d", d.devnum);
  text += "E: DEVNUM=" + std::string(number) + "\n";
  // sysfs attributes end in a newline; umockdev's format escapes it.
  const auto attribute = [&](const std::string& name, const std::string& value) {
    text += "A: " + name + "=" + value + "\\n\n";
  };
  const int minor = (d.busnum - 1) * 128 + d.devnum - 1;  // usbfs: 128 minors a bus
  attribute("dev", "189:" + std::to_string(minor));
  attribute("busnum", std::to_string(d.busnum));
  attribute("devnum", std::to_string(d.devnum));
  attribute("speed", "12");
  attribute("bConfigurationValue", "1");
  attribute("bNumConfigurations", "1");
  std::snprintf(ids, sizeof ids, "%04x", d.vendor_id);
  attribute("idVendor", ids);
  std::snprintf(ids, sizeof ids, "%04x", d.product_id);
  attribute("idProduct", ids);
  if (!d.manufacturer.empty()) attribute("manufacturer", d.manufacturer);
  if (!d.product.empty()) attribute("product", d.product);
  if (!d.serial.empty()) attribute("serial", d.serial);
  text += "H: descriptors=" + hex(descriptors()) + "\n";
  return text;
}

void UsbfsDevice::plug() {
  bed_.attach(devnode(), [this](UMockdevIoctlClient* client) { return on_ioctl(client); });
  bed_.add_from_string(description_text());
  const std::scoped_lock lock(mutex_);
  plugged_ = true;
}

void UsbfsDevice::unplug() {
  bed_.on_bed_thread([this] {
    {
      const std::scoped_lock lock(mutex_);
      if (!plugged_ || unplugged_) return;
      unplugged_ = true;
      plugged_ = false;
      for (Urb& urb : waiting_)
        complete_locked(urb, -ESHUTDOWN, 0);
      waiting_.clear();
    }
    umockdev_testbed_uevent(bed_.testbed(), syspath().c_str(), "remove");
    bed_.remove_device(syspath());
  });
}

void UsbfsDevice::queue_in(std::uint8_t endpoint, std::vector<std::uint8_t> data) {
  bed_.on_bed_thread([&] {
    const std::scoped_lock lock(mutex_);
    if (unplugged_) return;
    const auto waiting = std::find_if(waiting_.begin(), waiting_.end(),
                                      [&](const Urb& urb) { return urb.endpoint == endpoint; });
    if (waiting == waiting_.end()) {
      in_queues_[endpoint].push_back(std::move(data));
      return;
    }
    Urb urb = *waiting;
    waiting_.erase(waiting);
    fill_locked(urb, std::move(data));
  });
}

void UsbfsDevice::stall(std::uint8_t endpoint, int times) {
  bed_.on_bed_thread([&] {
    const std::scoped_lock lock(mutex_);
    stalls_left_[endpoint] += times;
    const auto waiting = std::find_if(waiting_.begin(), waiting_.end(),
                                      [&](const Urb& urb) { return urb.endpoint == endpoint; });
    if (waiting == waiting_.end()) return;
    Urb urb = *waiting;
    waiting_.erase(waiting);
    halts_locked(urb);
  });
}

bool UsbfsDevice::on_ioctl(UMockdevIoctlClient* client) {
  const unsigned long request = umockdev_ioctl_client_get_request(client);
  {
    const std::scoped_lock lock(mutex_);
    // Gone: only the URBs that completed before can still be reaped.
    if (unplugged_ && request != USBDEVFS_REAPURBNDELAY) return answer(client, -1, ENODEV);
  }
  switch (request) {
    case USBDEVFS_GET_CAPABILITIES: {
      Pointee<std::uint32_t> caps(client);
      if (!caps) return answer(client, -1, EFAULT);
      *caps = USBDEVFS_CAP_ZERO_PACKET | USBDEVFS_CAP_BULK_CONTINUATION |
              USBDEVFS_CAP_NO_PACKET_SIZE_LIM | USBDEVFS_CAP_REAP_AFTER_DISCONNECT;
      return answer(client, 0);
    }
    case USBDEVFS_CLAIMINTERFACE:
      return claim(client, false);
    case USBDEVFS_RELEASEINTERFACE:
      return claim(client, true);
    case USBDEVFS_CLEAR_HALT: {
      Pointee<unsigned> endpoint(client);
      if (!endpoint) return answer(client, -1, EFAULT);
      const bool known = std::any_of(description_.endpoints.begin(), description_.endpoints.end(),
                                     [&](const Endpoint& e) { return e.address == *endpoint; });
      if (!known) return answer(client, -1, ENOENT);
      const std::scoped_lock lock(mutex_);
      const auto address = static_cast<std::uint8_t>(*endpoint);
      halted_.erase(address);
      ++halts_cleared_[address];
      return answer(client, 0);
    }
    case USBDEVFS_SUBMITURB: {
      std::vector<std::uint8_t> data;
      std::uint8_t endpoint = 0;
      if (submit(client, data, endpoint) && on_out_) on_out_(endpoint, std::move(data));
      return true;
    }
    case USBDEVFS_REAPURBNDELAY:
      return reap(client);
    case USBDEVFS_DISCARDURB:
      return discard(client);
    default:
      return false;  // ENOTTY, as usbfs answers what it does not know
  }
}

bool UsbfsDevice::claim(UMockdevIoctlClient* client, bool release_it) {
  Pointee<unsigned> interface(client);
  if (!interface) return answer(client, -1, EFAULT);
  if (*interface != 0) return answer(client, -1, ENOENT);  // configuration 1 has interface 0
  const std::scoped_lock lock(mutex_);
  const auto held = claims_.find(*interface);
  if (release_it) {
    if (held == claims_.end() || held->second != client) return answer(client, -1, EINVAL);
    claims_.erase(held);
    return answer(client, 0);
  }
  if (held != claims_.end() && held->second != client) return answer(client, -1, EBUSY);
  claims_[*interface] = client;
  return answer(client, 0);
}

bool UsbfsDevice::submit(UMockdevIoctlClient* client, std::vector<std::uint8_t>& out_data,
                         std::uint8_t& out_endpoint) {
  Pointee<usbdevfs_urb> view(client);
  if (!view) return !answer(client, -1, EFAULT);
  g_object_ref(client);
  Urb urb{client, view.data()->client_addr, view->endpoint,
          static_cast<UMockdevIoctlData*>(g_object_ref(view.data())), nullptr};
  const auto refuse = [&](int error) {
    release(urb);
    return !answer(client, -1, error);
  };
  if (view->buffer_length < 0) return refuse(EINVAL);
  if (view->buffer_length > 0) {
    urb.buffer = umockdev_ioctl_data_resolve(view.data(), offsetof(usbdevfs_urb, buffer),
                                             static_cast<gsize>(view->buffer_length), nullptr);
    if (!urb.buffer) return refuse(EFAULT);
  }

  if (view->type == USBDEVFS_URB_TYPE_CONTROL) {
    if (urb.endpoint != 0 || view->buffer_length < 8) return refuse(EINVAL);
    control(urb);
    return !answer(client, 0);
  }
  const bool known = std::any_of(description_.endpoints.begin(), description_.endpoints.end(),
                                 [&](const Endpoint& e) { return e.address == urb.endpoint; });
  if (!known) return refuse(ENOENT);
  if (view->type != USBDEVFS_URB_TYPE_BULK && view->type != USBDEVFS_URB_TYPE_INTERRUPT)
    return refuse(EINVAL);
  bool delivered = false;
  {
    const std::scoped_lock lock(mutex_);
    if (halts_locked(urb)) {
      // The submission succeeded; the URB completes with the stall.
    } else if ((urb.endpoint & USB_DIR_IN) == 0) {
      // An OUT packet taken: it completes, then the firmware sees it.
      if (urb.buffer) out_data.assign(urb.buffer->data, urb.buffer->data + urb.buffer->data_len);
      out_endpoint = urb.endpoint;
      complete_locked(urb, 0, view->buffer_length);
      delivered = true;
    } else if (auto& queue = in_queues_[urb.endpoint]; !queue.empty()) {
      fill_locked(urb, std::move(queue.front()));
      queue.pop_front();
    } else {
      waiting_.push_back(urb);
    }
  }
  answer(client, 0);
  return delivered;
}

void UsbfsDevice::control(Urb& urb) {
  const std::uint8_t* setup = urb.buffer->data;
  const std::uint8_t request_type = setup[0];
  const std::uint8_t request = setup[1];
  const unsigned value = setup[2] | (setup[3] << 8);
  const unsigned length = setup[6] | (setup[7] << 8);
  std::optional<std::vector<std::uint8_t>> reply;
  if (request_type == (USB_DIR_IN | USB_TYPE_STANDARD | USB_RECIP_DEVICE)) {
    if (request == USB_REQ_GET_DESCRIPTOR) {
      const auto all = descriptors();
      switch (value >> 8) {
        case USB_DT_DEVICE:
          reply.emplace(all.begin(), all.begin() + 18);
          break;
        case USB_DT_CONFIG:
          if ((value & 0xFF) == 0) reply.emplace(all.begin() + 18, all.end());
          break;
        case USB_DT_STRING:
          if (auto text = string_descriptor(static_cast<int>(value & 0xFF)); !text.empty())
            reply = std::move(text);
          break;
        default:
          break;
      }
    } else if (request == USB_REQ_GET_STATUS) {
      reply = std::vector<std::uint8_t>{0, 0};
    } else if (request == USB_REQ_GET_CONFIGURATION) {
      reply = std::vector<std::uint8_t>{1};
    }
  }
  const std::scoped_lock lock(mutex_);
  if (!reply) {
    complete_locked(urb, -EPIPE, 0);  // a request the device refuses: a protocol stall
    return;
  }
  const auto room = static_cast<std::size_t>(urb.buffer->data_len - 8);
  const std::size_t n = std::min({reply->size(), static_cast<std::size_t>(length), room});
  std::memcpy(urb.buffer->data + 8, reply->data(), n);
  complete_locked(urb, 0, static_cast<int>(n));
}

bool UsbfsDevice::halts_locked(Urb& urb) {
  if (!halted_.contains(urb.endpoint)) {
    auto stalls = stalls_left_.find(urb.endpoint);
    if (stalls == stalls_left_.end() || stalls->second == 0) return false;
    --stalls->second;
    halted_.insert(urb.endpoint);
  }
  complete_locked(urb, -EPIPE, 0);
  return true;
}

void UsbfsDevice::fill_locked(Urb& urb, std::vector<std::uint8_t> data) {
  const std::size_t room = urb.buffer ? static_cast<std::size_t>(urb.buffer->data_len) : 0;
  const std::size_t n = std::min(room, data.size());
  if (n > 0) std::memcpy(urb.buffer->data, data.data(), n);
  // More than the host asked for is babble, as on the wire.
  complete_locked(urb, data.size() > room ? -EOVERFLOW : 0, static_cast<int>(n));
}

void UsbfsDevice::complete_locked(Urb urb, int status, int actual_length) {
  auto* raw = reinterpret_cast<usbdevfs_urb*>(urb.urb->data);
  raw->status = status;
  raw->actual_length = actual_length;
  ready_.push_back(urb);
}

bool UsbfsDevice::reap(UMockdevIoctlClient* client) {
  std::unique_lock lock(mutex_);
  const auto done = std::find_if(ready_.begin(), ready_.end(),
                                 [&](const Urb& urb) { return urb.client == client; });
  if (done == ready_.end()) {
    const bool gone = unplugged_;
    lock.unlock();
    return answer(client, -1, gone ? ENODEV : EAGAIN);
  }
  Urb urb = *done;
  ready_.erase(done);
  lock.unlock();
  // The kernel writes the URB's address where the argument points; umockdev
  // writes the URB itself (status, length, data) back with it.
  Pointee<void*> slot(client);
  if (!slot) {
    release(urb);
    return answer(client, -1, EFAULT);
  }
  umockdev_ioctl_data_set_ptr(slot.data(), 0, urb.urb);
  answer(client, 0);
  release(urb);  // the answer holds what it still needs
  return true;
}

bool UsbfsDevice::discard(UMockdevIoctlClient* client) {
  // The argument is the URB's address itself, not a pointer to read.
  const unsigned long address =
      *reinterpret_cast<const unsigned long*>(umockdev_ioctl_client_get_arg(client)->data);
  const std::scoped_lock lock(mutex_);
  const auto waiting = std::find_if(waiting_.begin(), waiting_.end(), [&](const Urb& urb) {
    return urb.client == client && urb.address == address;
  });
  if (waiting == waiting_.end()) return answer(client, -1, EINVAL);  // done already
  Urb urb = *waiting;
  waiting_.erase(waiting);
  complete_locked(urb, -ENOENT, 0);
  return answer(client, 0);
}

void UsbfsDevice::release(Urb& urb) {
  if (urb.buffer) g_object_unref(urb.buffer);
  if (urb.urb) g_object_unref(urb.urb);
  if (urb.client) g_object_unref(urb.client);
  urb = {};
}

}  // namespace psrig::test
