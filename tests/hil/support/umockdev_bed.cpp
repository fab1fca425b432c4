#include "umockdev_bed.h"

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <future>
#include <stdexcept>

namespace psrig::test {

// (umockdev_in_mock_environment() only turns true once a testbed exists.)
bool UmockdevBed::available() {
  const char* preload = std::getenv("LD_PRELOAD");
  return preload && std::strstr(preload, "libumockdev-preload");
}

// Handlers are attached from the test's thread, where no main context is
// thread-default, so umockdev serves them on the global default context;
// our thread runs that one.
UmockdevBed::UmockdevBed() : bed_(umockdev_testbed_new()) {
  context_ = g_main_context_ref(g_main_context_default());
  loop_ = g_main_loop_new(context_, FALSE);
  thread_ = std::thread([this] { g_main_loop_run(loop_); });
  // A quit before the run starts would be lost (run sets the loop running
  // again) and the destructor would wait for ever.
  while (!g_main_loop_is_running(loop_))
    std::this_thread::yield();
}

UmockdevBed::~UmockdevBed() {
  {
    std::lock_guard lock(mutex_);
    for (auto& [devnode, attached] : attached_) {
      umockdev_testbed_detach_ioctl(bed_, devnode.c_str(), nullptr);
      g_object_unref(attached->base);
      delete attached;
    }
    attached_.clear();
  }
  g_main_loop_quit(loop_);
  if (thread_.joinable()) thread_.join();
  g_main_loop_unref(loop_);
  g_main_context_unref(context_);
  g_object_unref(bed_);
}

std::string UmockdevBed::root() const {
  gchar* dir = umockdev_testbed_get_root_dir(bed_);
  std::string root(dir);
  g_free(dir);
  return root;
}

std::string UmockdevBed::add_device(
    const std::string& subsystem, const std::string& name, const std::string& parent,
    const std::vector<std::pair<std::string, std::string>>& attributes,
    const std::vector<std::pair<std::string, std::string>>& properties) {
  const auto flatten = [](const std::vector<std::pair<std::string, std::string>>& pairs) {
    std::vector<gchar*> flat;
    for (const auto& [key, value] : pairs) {
      flat.push_back(const_cast<gchar*>(key.c_str()));
      flat.push_back(const_cast<gchar*>(value.c_str()));
    }
    flat.push_back(nullptr);
    return flat;
  };
  auto attrs = flatten(attributes);
  auto props = flatten(properties);
  gchar* syspath = umockdev_testbed_add_devicev(bed_, subsystem.c_str(), name.c_str(),
                                                parent.empty() ? nullptr : parent.c_str(),
                                                attrs.data(), props.data());
  if (!syspath) throw std::runtime_error("umockdev: cannot add device " + name);
  std::string result(syspath);
  g_free(syspath);
  return result;
}

void UmockdevBed::add_from_string(const std::string& description) {
  GError* error = nullptr;
  if (!umockdev_testbed_add_from_string(bed_, description.c_str(), &error)) {
    const std::string message = error ? error->message : "unknown error";
    g_clear_error(&error);
    throw std::runtime_error("umockdev: cannot add devices: " + message);
  }
}

void UmockdevBed::remove_device(const std::string& syspath) {
  umockdev_testbed_remove_device(bed_, syspath.c_str());
}

void UmockdevBed::add_bus_link(const std::string& bus, const std::string& syspath) {
  namespace fs = std::filesystem;
  const fs::path devices = fs::path(root()) / "sys" / "bus" / bus / "devices";
  fs::create_directories(devices);
  const fs::path device = fs::path(syspath).lexically_relative("/sys");
  const fs::path link = devices / device.filename();
  if (fs::exists(fs::symlink_status(link))) return;  // newer umockdev makes it
  fs::create_symlink(fs::path("../../..") / device, link);
}

void UmockdevBed::add_udev_entry(unsigned major, unsigned minor) {
  namespace fs = std::filesystem;
  const fs::path data = fs::path(root()) / "run" / "udev" / "data";
  fs::create_directories(data);
  std::ofstream(data / ("c" + std::to_string(major) + ":" + std::to_string(minor))) << "I:1\n";
}

gboolean UmockdevBed::dispatch_ioctl(UMockdevIoctlBase*, UMockdevIoctlClient* client,
                                     gpointer attached) {
  auto* a = static_cast<Attached*>(attached);
  if (a->on_ioctl && a->on_ioctl(client)) return TRUE;
  umockdev_ioctl_client_complete(client, -1, ENOTTY);
  return TRUE;
}
gboolean UmockdevBed::dispatch_read(UMockdevIoctlBase*, UMockdevIoctlClient* client,
                                    gpointer attached) {
  auto* a = static_cast<Attached*>(attached);
  if (a->on_read && a->on_read(client)) return TRUE;
  umockdev_ioctl_client_complete(client, -1, EIO);
  return TRUE;
}
gboolean UmockdevBed::dispatch_write(UMockdevIoctlBase*, UMockdevIoctlClient* client,
                                     gpointer attached) {
  auto* a = static_cast<Attached*>(attached);
  if (a->on_write && a->on_write(client)) return TRUE;
  umockdev_ioctl_client_complete(client, -1, EIO);
  return TRUE;
}

void UmockdevBed::attach(const std::string& devnode, Handler on_ioctl, Handler on_read,
                         Handler on_write) {
  auto* attached = new Attached{umockdev_ioctl_base_new(), std::move(on_ioctl), std::move(on_read),
                                std::move(on_write)};
  // After the base class's own handler, which declines everything.
  g_signal_connect_after(attached->base, "handle-ioctl", G_CALLBACK(dispatch_ioctl), attached);
  g_signal_connect_after(attached->base, "handle-read", G_CALLBACK(dispatch_read), attached);
  g_signal_connect_after(attached->base, "handle-write", G_CALLBACK(dispatch_write), attached);
  GError* error = nullptr;
  const gboolean ok = umockdev_testbed_attach_ioctl(bed_, devnode.c_str(), attached->base, &error);
  if (!ok) {
    const std::string message = error ? error->message : "unknown error";
    g_clear_error(&error);
    g_object_unref(attached->base);
    delete attached;
    throw std::runtime_error("umockdev: cannot attach to " + devnode + ": " + message);
  }
  std::lock_guard lock(mutex_);
  attached_[devnode] = attached;
}

void UmockdevBed::detach(const std::string& devnode) {
  std::lock_guard lock(mutex_);
  const auto it = attached_.find(devnode);
  if (it == attached_.end()) return;
  umockdev_testbed_detach_ioctl(bed_, devnode.c_str(), nullptr);
  g_object_unref(it->second->base);
  delete it->second;
  attached_.erase(it);
}

}  // namespace psrig::test

namespace psrig::test {

void UmockdevBed::on_bed_thread(const std::function<void()>& f) {
  if (g_main_context_is_owner(context_)) {
    f();
    return;
  }
  struct Call {
    const std::function<void()>* f;
    std::promise<void> done;
  } call{&f, {}};
  auto done = call.done.get_future();
  g_main_context_invoke(
      context_,
      [](gpointer data) -> gboolean {
        auto* c = static_cast<Call*>(data);
        (*c->f)();
        c->done.set_value();
        return G_SOURCE_REMOVE;
      },
      &call);
  done.wait();
}

}  // namespace psrig::test
