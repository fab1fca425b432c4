#pragma once
// The U3MA container (u3m_additional_spec_u3ma.txt): a zip restricted to
// stored or deflated entries, UTF-8 names with the EFS flag, no extra
// fields, comments, attributes, data descriptors or zip64, version needed
// 2.0, made by "FAT" 6.3, times in UTC. Written with minizip.

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "psrig/base/error.h"

namespace psrig::export_ {

struct ArchiveEntry {
  std::string name;  // relative path, '/' separated
  std::vector<unsigned char> bytes;
  bool deflate = true;  // PNGs are already deflated: store them
};

// Writes `entries` to `file` (which must not exist yet).
[[nodiscard]] Status write_u3ma(const std::filesystem::path& file,
                                const std::vector<ArchiveEntry>& entries);

}  // namespace psrig::export_
