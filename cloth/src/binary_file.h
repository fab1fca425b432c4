#pragma once
// What the cloth library's binary files (the woven data set, the woven
// network's weights) share: little-endian values appended to a buffer and
// written whole through a temporary renamed into place, and a reader that
// checks every count against the bytes left before it trusts it.

#include <bit>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "psrig/base/error.h"

namespace psrig::cloth::binary {

// Both machines psrig runs on (x86-64, arm64) are little-endian, so values
// are copied as they lie in memory; a big-endian port would swap here.
static_assert(std::endian::native == std::endian::little, "psrig's binary files are little-endian");

class Writer {
 public:
  void bytes(const void* data, std::size_t size);
  void u32(std::uint32_t value) { bytes(&value, sizeof value); }
  void u64(std::uint64_t value) { bytes(&value, sizeof value); }
  void f32(float value) { bytes(&value, sizeof value); }
  void floats(std::span<const float> values) { bytes(values.data(), values.size_bytes()); }
  void text(std::string_view value);  // u32 length, then the bytes
  [[nodiscard]] const std::vector<char>& buffer() const { return buffer_; }

 private:
  std::vector<char> buffer_;
};

// The whole buffer to `file` through `file.tmp` renamed over it, so a
// reader never sees half a file and a failed write leaves the old one.
[[nodiscard]] Status write_file_atomically(const std::filesystem::path& file,
                                           const std::vector<char>& buffer);
[[nodiscard]] Result<std::vector<char>> read_whole_file(const std::filesystem::path& file);

// Reads values off a file's bytes; every failure names the file, the byte
// offset and what was being read.
class Reader {
 public:
  Reader(std::filesystem::path file, const std::vector<char>& bytes)
      : file_(std::move(file)), bytes_(bytes) {}

  [[nodiscard]] std::size_t left() const { return bytes_.size() - offset_; }
  [[nodiscard]] std::size_t offset() const { return offset_; }
  [[nodiscard]] Status expect_magic(std::string_view magic);
  [[nodiscard]] Result<std::uint32_t> u32(std::string_view what);
  [[nodiscard]] Result<std::uint64_t> u64(std::string_view what);
  [[nodiscard]] Result<float> f32(std::string_view what);
  // `count` floats, checked against the bytes left first.
  [[nodiscard]] Result<std::vector<float>> floats(std::uint64_t count, std::string_view what);
  [[nodiscard]] Result<std::string> text(std::string_view what);
  // Reads `size` raw bytes into `out` (checked).
  [[nodiscard]] Status raw(void* out, std::size_t size, std::string_view what);
  // An error about this file at the current offset.
  [[nodiscard]] Error fail(std::string_view message) const;

 private:
  std::filesystem::path file_;
  const std::vector<char>& bytes_;
  std::size_t offset_ = 0;
};

}  // namespace psrig::cloth::binary
