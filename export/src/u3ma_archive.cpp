#include "u3ma_archive.h"

#include <ctime>
#include <minizip/zip.h>

namespace psrig::export_ {
namespace {

// MS-DOS date and time of `t`, in UTC as the spec asks.
uLong dos_time_utc(std::time_t t) {
  std::tm utc{};
  gmtime_r(&t, &utc);
  const uLong date =
      static_cast<uLong>(((utc.tm_year - 80) << 9) | ((utc.tm_mon + 1) << 5) | utc.tm_mday);
  const uLong time = static_cast<uLong>((utc.tm_hour << 11) | (utc.tm_min << 5) | (utc.tm_sec / 2));
  return (date << 16) | time;
}

constexpr uLong kEfsFlag = 1u << 11;      // names are UTF-8
constexpr uLong kVersionMadeBy = 0x003F;  // "FAT", spec 6.3: the spec's fixed value

}  // namespace

Status write_u3ma(const std::filesystem::path& file, const std::vector<ArchiveEntry>& entries) {
  zipFile zip = zipOpen64(file.c_str(), APPEND_STATUS_CREATE);
  if (!zip) return std::unexpected(io_error(file, "cannot create the archive"));
  const uLong when = dos_time_utc(std::time(nullptr));
  for (const auto& entry : entries) {
    zip_fileinfo info{};
    info.dosDate = when;
    info.internal_fa = 0;
    info.external_fa = 0;  // the spec forbids attributes
    const int method = entry.deflate ? Z_DEFLATED : 0;
    // zip64 = 0: no zip64 extra field; no extra fields, no comment.
    int rc =
        zipOpenNewFileInZip4_64(zip, entry.name.c_str(), &info, nullptr, 0, nullptr, 0, nullptr,
                                method, Z_DEFAULT_COMPRESSION, 0, -MAX_WBITS, DEF_MEM_LEVEL,
                                Z_DEFAULT_STRATEGY, nullptr, 0, kVersionMadeBy, kEfsFlag, 0);
    if (rc == ZIP_OK && !entry.bytes.empty())
      rc = zipWriteInFileInZip(zip, entry.bytes.data(), static_cast<unsigned>(entry.bytes.size()));
    if (rc == ZIP_OK) rc = zipCloseFileInZip(zip);
    if (rc != ZIP_OK) {
      zipClose(zip, nullptr);
      return std::unexpected(io_error(file, "cannot write " + entry.name + " into the archive"));
    }
  }
  if (zipClose(zip, nullptr) != ZIP_OK)
    return std::unexpected(io_error(file, "cannot finish the archive"));
  return {};
}

}  // namespace psrig::export_
