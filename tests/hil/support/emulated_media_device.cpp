#include "emulated_media_device.h"

#include <algorithm>
#include <cerrno>
#include <cstddef>
#include <cstring>
#include <linux/media.h>

namespace psrig::test {
namespace {

void copy_string(char* dst, std::size_t size, const std::string& s) {
  std::memset(dst, 0, size);
  std::memcpy(dst, s.data(), std::min(s.size(), size - 1));
}

// The caller's array at the pointer `offset` bytes into the topology, if it
// gave one: ENOSPC when it is shorter than `items`, as the media core says.
template <class T, class Fill>
int fill_array(UMockdevIoctlData* topology, std::size_t pointer_offset, std::size_t count_offset,
               const std::vector<T>& items, Fill fill) {
  auto* bytes = reinterpret_cast<std::uint8_t*>(topology->data);
  std::uint64_t pointer = 0;
  std::uint32_t room = 0;
  std::memcpy(&pointer, bytes + pointer_offset, sizeof pointer);
  std::memcpy(&room, bytes + count_offset, sizeof room);
  const auto count = static_cast<std::uint32_t>(items.size());
  std::memcpy(bytes + count_offset, &count, sizeof count);
  if (pointer == 0 || items.empty()) return 0;
  if (room < count) return ENOSPC;
  using Entry = decltype(fill(items.front()));
  UMockdevIoctlData* array =
      umockdev_ioctl_data_resolve(topology, pointer_offset, sizeof(Entry) * count, nullptr);
  if (!array) return EFAULT;
  for (std::size_t i = 0; i < items.size(); ++i) {
    const Entry entry = fill(items[i]);
    std::memcpy(array->data + i * sizeof(Entry), &entry, sizeof entry);
  }
  umockdev_ioctl_data_unref(array);
  return 0;
}

}  // namespace

EmulatedMediaDevice::EmulatedMediaDevice(UmockdevBed& bed, EmulatedMediaOptions options)
    : bed_(bed), options_(std::move(options)) {
  bed_.attach(devnode(), [this](UMockdevIoctlClient* client) { return handle(client); });
  // A regular file (contents given), not a PTY: nothing polls or maps it.
  const std::string devpath = options_.parent.substr(4) + "/" + options_.name;  // no /sys
  bed_.add_from_string(
      "P: " + devpath + "\nN: " + options_.name + "=00\nE: SUBSYSTEM=media\nE: DEVNAME=/dev/" +
      options_.name + "\nE: MAJOR=" + std::to_string(options_.major) + "\nE: MINOR=" +
      std::to_string(options_.minor) + "\nA: dev=" + std::to_string(options_.major) + ":" +
      std::to_string(options_.minor) + "\\n\nA: model=" + options_.model + "\\n\n");
  syspath_ = "/sys" + devpath;
}

EmulatedMediaDevice::~EmulatedMediaDevice() {
  bed_.detach(devnode());
}

void EmulatedMediaDevice::unplug() {
  bed_.on_bed_thread([this] {
    {
      std::lock_guard lock(mutex_);
      if (unplugged_) return;
      unplugged_ = true;
    }
    umockdev_testbed_uevent(bed_.testbed(), syspath_.c_str(), "remove");
    bed_.remove_device(syspath_);
  });
}

int EmulatedMediaDevice::requests() const {
  std::lock_guard lock(mutex_);
  return requests_;
}

bool EmulatedMediaDevice::handle(UMockdevIoctlClient* client) {
  std::lock_guard lock(mutex_);
  if (unplugged_) return answer(client, -1, ENODEV);
  ++requests_;
  switch (umockdev_ioctl_client_get_request(client)) {
    case MEDIA_IOC_DEVICE_INFO: {
      Pointee<media_device_info> info(client);
      *info = media_device_info{};
      copy_string(info->driver, sizeof info->driver, options_.driver);
      copy_string(info->model, sizeof info->model, options_.model);
      copy_string(info->serial, sizeof info->serial, options_.serial);
      copy_string(info->bus_info, sizeof info->bus_info, options_.bus_info);
      info->media_version = (6u << 16) | (1u << 8);  // 6.1: entities carry their flags
      info->hw_revision = 0x0100;
      info->driver_version = info->media_version;
      return answer(client, 0);
    }
    case MEDIA_IOC_G_TOPOLOGY: {
      const int error = topology(client);
      return error ? answer(client, -1, error) : answer(client, 0);
    }
    case MEDIA_IOC_ENUM_ENTITIES: {
      Pointee<media_entity_desc> desc(client);
      // The next entity after the id asked for, or that one.
      const bool next = desc->id & MEDIA_ENT_ID_FLAG_NEXT;
      const std::uint32_t id = desc->id & ~MEDIA_ENT_ID_FLAG_NEXT;
      const MediaGraph::Entity* found = nullptr;
      for (const auto& e : options_.graph.entities)
        if ((next ? e.id > id : e.id == id) && (!found || e.id < found->id)) found = &e;
      if (!found) return answer(client, -1, EINVAL);
      *desc = media_entity_desc{};
      desc->id = found->id;
      copy_string(desc->name, sizeof desc->name, found->name);
      desc->type = found->function;
      desc->flags = found->flags;
      for (const auto& p : options_.graph.pads)
        if (p.entity_id == found->id) ++desc->pads;
      for (const auto& l : options_.graph.links)
        if ((l.flags & MEDIA_LNK_FL_LINK_TYPE) == MEDIA_LNK_FL_DATA_LINK) {
          for (const auto& p : options_.graph.pads)
            if (p.id == l.source_id && p.entity_id == found->id) ++desc->links;
        }
      for (const auto& i : options_.graph.interfaces)
        for (const auto& l : options_.graph.links)
          if (l.source_id == i.id && l.sink_id == found->id) {
            desc->dev.major = i.major;
            desc->dev.minor = i.minor;
          }
      return answer(client, 0);
    }
    default:
      return false;  // ENOTTY
  }
}

int EmulatedMediaDevice::topology(UMockdevIoctlClient* client) {
  Pointee<media_v2_topology> t(client);
  if (!t) return EFAULT;
  t->topology_version = 1;  // never changes; 0 would tell callers there is none yet
  const MediaGraph& g = options_.graph;
  UMockdevIoctlData* data = t.data();
  int error = fill_array(data, offsetof(media_v2_topology, ptr_entities),
                         offsetof(media_v2_topology, num_entities), g.entities,
                         [](const MediaGraph::Entity& e) {
                           media_v2_entity out{};
                           out.id = e.id;
                           copy_string(out.name, sizeof out.name, e.name);
                           out.function = e.function;
                           out.flags = e.flags;
                           return out;
                         });
  if (!error)
    error = fill_array(data, offsetof(media_v2_topology, ptr_interfaces),
                       offsetof(media_v2_topology, num_interfaces), g.interfaces,
                       [](const MediaGraph::Interface& i) {
                         media_v2_interface out{};
                         out.id = i.id;
                         out.intf_type = i.type;
                         out.devnode.major = i.major;
                         out.devnode.minor = i.minor;
                         return out;
                       });
  if (!error)
    error = fill_array(data, offsetof(media_v2_topology, ptr_pads),
                       offsetof(media_v2_topology, num_pads), g.pads, [](const MediaGraph::Pad& p) {
                         media_v2_pad out{};
                         out.id = p.id;
                         out.entity_id = p.entity_id;
                         out.flags = p.flags;
                         out.index = p.index;
                         return out;
                       });
  if (!error)
    error =
        fill_array(data, offsetof(media_v2_topology, ptr_links),
                   offsetof(media_v2_topology, num_links), g.links, [](const MediaGraph::Link& l) {
                     media_v2_link out{};
                     out.id = l.id;
                     out.source_id = l.source_id;
                     out.sink_id = l.sink_id;
                     out.flags = l.flags;
                     return out;
                   });
  return error;
}

}  // namespace psrig::test
