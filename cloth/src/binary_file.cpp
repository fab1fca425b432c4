#include "binary_file.h"

#include <fmt/format.h>
#include <fstream>
#include <system_error>

namespace psrig::cloth::binary {

void Writer::bytes(const void* data, std::size_t size) {
  const auto* begin = static_cast<const char*>(data);
  buffer_.insert(buffer_.end(), begin, begin + size);
}

void Writer::text(std::string_view value) {
  u32(static_cast<std::uint32_t>(value.size()));
  bytes(value.data(), value.size());
}

Status write_file_atomically(const std::filesystem::path& file, const std::vector<char>& buffer) {
  std::filesystem::path temporary = file;
  temporary += ".tmp";
  {
    std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
    if (!out) {
      return std::unexpected(io_error(temporary, "cannot create the file"));
    }
    out.write(buffer.data(), static_cast<std::streamsize>(buffer.size()));
    out.flush();
    if (!out) {
      std::error_code ignored;
      std::filesystem::remove(temporary, ignored);
      return std::unexpected(io_error(temporary, "cannot write the file (disk full?)"));
    }
  }
  std::error_code error;
  std::filesystem::rename(temporary, file, error);
  if (error) {
    std::error_code ignored;
    std::filesystem::remove(temporary, ignored);
    return std::unexpected(
        io_error(file, "cannot rename the temporary into place: " + error.message()));
  }
  return {};
}

Result<std::vector<char>> read_whole_file(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary | std::ios::ate);
  if (!in) {
    return std::unexpected(io_error(file, "cannot open the file"));
  }
  const std::streamoff size = in.tellg();
  std::vector<char> bytes(static_cast<std::size_t>(size));
  in.seekg(0);
  in.read(bytes.data(), size);
  if (!in) {
    return std::unexpected(io_error(file, "cannot read the file"));
  }
  return bytes;
}

Error Reader::fail(std::string_view message) const {
  return bad_input(file_, "", fmt::format("at byte {}: {}", offset_, message));
}

Status Reader::raw(void* out, std::size_t size, std::string_view what) {
  if (size > left()) {
    return std::unexpected(fail(
        fmt::format("the file ends inside {} ({} bytes needed, {} left)", what, size, left())));
  }
  std::memcpy(out, bytes_.data() + offset_, size);
  offset_ += size;
  return {};
}

Status Reader::expect_magic(std::string_view magic) {
  if (left() < magic.size() || std::string_view(bytes_.data(), magic.size()) != magic) {
    return std::unexpected(
        fail(fmt::format("not a {} file (its first bytes are not \"{}\")",
                         magic.substr(0, magic.find('\n')), magic.substr(0, magic.find('\n')))));
  }
  offset_ += magic.size();
  return {};
}

Result<std::uint32_t> Reader::u32(std::string_view what) {
  std::uint32_t value = 0;
  if (auto ok = raw(&value, sizeof value, what); !ok) {
    return std::unexpected(ok.error());
  }
  return value;
}

Result<std::uint64_t> Reader::u64(std::string_view what) {
  std::uint64_t value = 0;
  if (auto ok = raw(&value, sizeof value, what); !ok) {
    return std::unexpected(ok.error());
  }
  return value;
}

Result<float> Reader::f32(std::string_view what) {
  float value = 0;
  if (auto ok = raw(&value, sizeof value, what); !ok) {
    return std::unexpected(ok.error());
  }
  return value;
}

Result<std::vector<float>> Reader::floats(std::uint64_t count, std::string_view what) {
  if (count > left() / sizeof(float)) {
    return std::unexpected(
        fail(fmt::format("{} says {} floats ({} bytes) but only {} bytes are left", what, count,
                         count * sizeof(float), left())));
  }
  std::vector<float> values(count);
  if (auto ok = raw(values.data(), count * sizeof(float), what); !ok) {
    return std::unexpected(ok.error());
  }
  return values;
}

Result<std::string> Reader::text(std::string_view what) {
  auto size = u32(what);
  if (!size) {
    return std::unexpected(size.error());
  }
  if (*size > left()) {
    return std::unexpected(
        fail(fmt::format("{} says {} bytes but only {} are left", what, *size, left())));
  }
  std::string value(bytes_.data() + offset_, *size);
  offset_ += *size;
  return value;
}

}  // namespace psrig::cloth::binary
