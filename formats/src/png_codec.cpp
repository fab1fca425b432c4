#include "png_codec.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fcntl.h>
#include <isa-l/crc.h>
#include <isa-l/igzip_lib.h>
#include <memory>
#include <optional>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>
#include <vector>

#include "psrig/base/parallel.h"
#include "psrig/base/vector_clones.h"

namespace psrig::formats::png {
namespace {

namespace fs = std::filesystem;

// As cv::imread: larger images are refused (2^30 pixels).
constexpr std::uint64_t kMaxPixels = std::uint64_t{1} << 30;
// PNG chunk lengths are 31-bit.
constexpr std::size_t kMaxChunk = 0x7FFFFFFF;
constexpr std::array<std::uint8_t, 8> kSignature = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};

std::uint32_t load_be32(const std::uint8_t* p) {
  return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) |
         p[3];
}
void store_be32(std::uint8_t* p, std::uint32_t v) {
  p[0] = static_cast<std::uint8_t>(v >> 24);
  p[1] = static_cast<std::uint8_t>(v >> 16);
  p[2] = static_cast<std::uint8_t>(v >> 8);
  p[3] = static_cast<std::uint8_t>(v);
}

struct FileCloser {
  void operator()(std::FILE* f) const { std::fclose(f); }
};
using File = std::unique_ptr<std::FILE, FileCloser>;

// A file mapped read-only: decoding reads it straight from the page cache,
// with no buffer to allocate and fill.
class MappedFile {
 public:
  explicit MappedFile(const fs::path& file) {
    const int fd = ::open(file.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) return;
    struct stat info {};
    if (::fstat(fd, &info) == 0 && info.st_size > 0) {
      void* map =
          ::mmap(nullptr, static_cast<std::size_t>(info.st_size), PROT_READ, MAP_PRIVATE, fd, 0);
      if (map != MAP_FAILED) {
        data_ = static_cast<const std::uint8_t*>(map);
        size_ = static_cast<std::size_t>(info.st_size);
        ::madvise(map, size_, MADV_SEQUENTIAL);
      }
    }
    ::close(fd);
  }
  ~MappedFile() {
    if (data_) ::munmap(const_cast<std::uint8_t*>(data_), size_);
  }
  MappedFile(const MappedFile&) = delete;
  MappedFile& operator=(const MappedFile&) = delete;
  [[nodiscard]] const std::uint8_t* data() const { return data_; }
  [[nodiscard]] std::size_t size() const { return size_; }

 private:
  const std::uint8_t* data_ = nullptr;
  std::size_t size_ = 0;
};

// PNG's Paeth predictor (PNG specification, section 9.4).
std::uint8_t paeth(int a, int b, int c) {
  const int p = a + b - c;
  const int pa = std::abs(p - a), pb = std::abs(p - b), pc = std::abs(p - c);
  return static_cast<std::uint8_t>(pa <= pb && pa <= pc ? a : pb <= pc ? b : c);
}

// Undoes one row's filter in place; `previous` is the unfiltered row above
// (zeros for the first row), `bpp` bytes per pixel.
bool unfilter_row(std::uint8_t type, std::uint8_t* row, const std::uint8_t* previous, std::size_t n,
                  std::size_t bpp) {
  switch (type) {
    case 0:
      return true;
    case 1:
      for (std::size_t i = bpp; i < n; ++i)
        row[i] = static_cast<std::uint8_t>(row[i] + row[i - bpp]);
      return true;
    case 2:
      for (std::size_t i = 0; i < n; ++i)
        row[i] = static_cast<std::uint8_t>(row[i] + previous[i]);
      return true;
    case 3:
      for (std::size_t i = 0; i < n; ++i) {
        const int left = i >= bpp ? row[i - bpp] : 0;
        row[i] = static_cast<std::uint8_t>(row[i] + ((left + previous[i]) >> 1));
      }
      return true;
    case 4:
      for (std::size_t i = 0; i < n; ++i) {
        const int left = i >= bpp ? row[i - bpp] : 0;
        const int upper_left = i >= bpp ? previous[i - bpp] : 0;
        row[i] = static_cast<std::uint8_t>(row[i] + paeth(left, previous[i], upper_left));
      }
      return true;
    default:
      return false;
  }
}

// PNG byte order (RGB, big-endian samples) to OpenCV's (BGR, native), and back.
PSRIG_VECTOR_CLONES
void rgb16_to_bgr(const std::uint8_t* __restrict in, std::uint16_t* __restrict out, int pixels) {
  for (int i = 0; i < pixels; ++i) {
    out[3 * i] = static_cast<std::uint16_t>(in[6 * i + 4] << 8 | in[6 * i + 5]);
    out[3 * i + 1] = static_cast<std::uint16_t>(in[6 * i + 2] << 8 | in[6 * i + 3]);
    out[3 * i + 2] = static_cast<std::uint16_t>(in[6 * i] << 8 | in[6 * i + 1]);
  }
}
PSRIG_VECTOR_CLONES
void grey16_from_be(const std::uint8_t* __restrict in, std::uint16_t* __restrict out, int samples) {
  for (int i = 0; i < samples; ++i)
    out[i] = static_cast<std::uint16_t>(in[2 * i] << 8 | in[2 * i + 1]);
}
PSRIG_VECTOR_CLONES
void rgb8_to_bgr(const std::uint8_t* __restrict in, std::uint8_t* __restrict out, int pixels) {
  for (int i = 0; i < pixels; ++i) {
    out[3 * i] = in[3 * i + 2];
    out[3 * i + 1] = in[3 * i + 1];
    out[3 * i + 2] = in[3 * i];
  }
}
PSRIG_VECTOR_CLONES
void bgr16_to_rgb_be(const std::uint16_t* __restrict in, std::uint8_t* __restrict out, int pixels) {
  for (int i = 0; i < pixels; ++i) {
    const std::uint16_t b = in[3 * i], g = in[3 * i + 1], r = in[3 * i + 2];
    out[6 * i] = static_cast<std::uint8_t>(r >> 8);
    out[6 * i + 1] = static_cast<std::uint8_t>(r);
    out[6 * i + 2] = static_cast<std::uint8_t>(g >> 8);
    out[6 * i + 3] = static_cast<std::uint8_t>(g);
    out[6 * i + 4] = static_cast<std::uint8_t>(b >> 8);
    out[6 * i + 5] = static_cast<std::uint8_t>(b);
  }
}
PSRIG_VECTOR_CLONES
void grey16_to_be(const std::uint16_t* __restrict in, std::uint8_t* __restrict out, int samples) {
  for (int i = 0; i < samples; ++i) {
    out[2 * i] = static_cast<std::uint8_t>(in[i] >> 8);
    out[2 * i + 1] = static_cast<std::uint8_t>(in[i]);
  }
}
PSRIG_VECTOR_CLONES
void subtract_row(std::uint8_t* __restrict row, const std::uint8_t* __restrict above,
                  std::size_t n) {
  for (std::size_t i = 0; i < n; ++i)
    row[i] = static_cast<std::uint8_t>(row[i] - above[i]);
}

}  // namespace

// A file read where asked (pread): the reader holds no mapping of it, so
// a frame read a band at a time takes no address space for its bytes.
class ReadFile {
 public:
  explicit ReadFile(const fs::path& file) : fd_(::open(file.c_str(), O_RDONLY | O_CLOEXEC)) {
    struct stat info {};
    if (fd_ >= 0 && ::fstat(fd_, &info) == 0 && S_ISREG(info.st_mode))
      size_ = static_cast<std::size_t>(info.st_size);
  }
  ~ReadFile() {
    if (fd_ >= 0) ::close(fd_);
  }
  ReadFile(const ReadFile&) = delete;
  ReadFile& operator=(const ReadFile&) = delete;
  [[nodiscard]] std::size_t size() const { return size_; }
  // n bytes at `offset`, all of them, or false.
  bool read(std::size_t offset, void* out, std::size_t n) const {
    auto* bytes = static_cast<std::uint8_t*>(out);
    while (n > 0) {
      const ssize_t got = ::pread(fd_, bytes, n, static_cast<off_t>(offset));
      if (got <= 0) return false;
      bytes += got;
      offset += static_cast<std::size_t>(got);
      n -= static_cast<std::size_t>(got);
    }
    return true;
  }

 private:
  int fd_;
  std::size_t size_ = 0;
};

// The reader's state: the file, its IDAT pieces, the inflater.
struct Reader::State {
  explicit State(const fs::path& path) : file(path) {}
  struct Piece {
    std::size_t offset;  // of the payload in the file
    std::uint32_t length;
  };
  ReadFile file;
  std::vector<Piece> idat;  // the zlib stream, in pieces
  std::size_t next_piece = 0;
  std::uint32_t piece_read = 0;  // bytes of idat[next_piece] read so far
  std::uint32_t crc = 0;         // of idat[next_piece] so far, its type first
  std::vector<std::uint8_t> input;
  std::uint32_t width = 0, height = 0;
  int bit_depth = 0, channels = 0;
  std::size_t bpp = 0, row_bytes = 0;
  std::uint32_t rows_read = 0;
  inflate_state inflater{};
  std::vector<std::uint8_t> buffer;  // a batch of raw rows, filter bytes first
  std::vector<std::uint8_t> above;   // the row before the batch, unfiltered

  // The next stretch of image data (up to 1 MB) given to the inflater; each
  // IDAT's CRC checked once its last byte is read. False when the data
  // cannot be read or a CRC is wrong; true with nothing given at the end.
  bool refill() {
    constexpr std::size_t kInput = std::size_t{1} << 20;
    while (next_piece < idat.size()) {
      const Piece& piece = idat[next_piece];
      if (piece_read == 0)
        crc = crc32_gzip_refl(0, reinterpret_cast<const std::uint8_t*>("IDAT"), 4);
      const auto n =
          static_cast<std::uint32_t>(std::min<std::size_t>(kInput, piece.length - piece_read));
      input.resize(std::max<std::size_t>(input.size(), n));
      if (n > 0 && !file.read(piece.offset + piece_read, input.data(), n)) return false;
      crc = crc32_gzip_refl(crc, input.data(), n);
      piece_read += n;
      if (piece_read == piece.length) {
        std::uint8_t stored[4];
        if (!file.read(piece.offset + piece.length, stored, 4) || load_be32(stored) != crc)
          return false;
        ++next_piece;
        piece_read = 0;
      }
      if (n > 0) {
        inflater.next_in = input.data();
        inflater.avail_in = n;
        return true;
      }
    }
    return true;
  }
  // One call of the inflater, given more image data when it has used up
  // what it had; false when the stream is damaged or nothing moved (no data
  // left: the inflater may still hold a few bytes of input, so it is called
  // even when none is left to give it).
  bool step() {
    if (inflater.avail_in == 0 && !refill()) return false;
    const auto in = inflater.avail_in;
    const auto out = inflater.avail_out;
    const auto block = inflater.block_state;
    if (isal_inflate(&inflater) != ISAL_DECOMP_OK) return false;
    return inflater.avail_in != in || inflater.avail_out != out || inflater.block_state != block;
  }
  // Exactly n bytes of the stream into out; false if it ends before or is damaged.
  bool inflate_into(std::uint8_t* out, std::size_t n) {
    inflater.next_out = out;
    inflater.avail_out = static_cast<std::uint32_t>(n);
    while (inflater.avail_out > 0)
      if (inflater.block_state == ISAL_BLOCK_FINISH || !step()) return false;
    return true;
  }
  // The end of the stream, its checksum checked, and no more image data.
  bool finish() {
    std::uint8_t extra = 0;
    inflater.next_out = &extra;
    inflater.avail_out = 1;
    while (inflater.block_state != ISAL_BLOCK_FINISH)
      if (!step() || inflater.avail_out == 0) return false;
    return true;
  }
};

Reader::Reader(std::unique_ptr<State> state) : state_(std::move(state)) {}
Reader::Reader(Reader&&) noexcept = default;
Reader& Reader::operator=(Reader&&) noexcept = default;
Reader::~Reader() = default;

// The chunks walked from their headers: IHDR and IEND checked whole (CRC
// included), the IDATs' places noted, each checked as it is read.
std::optional<Reader> Reader::open(const fs::path& file) {
  auto state = std::make_unique<State>(file);
  State& s = *state;
  const std::size_t size = s.file.size();
  std::uint8_t signature[8];
  if (size < kSignature.size() + 12 + 13 || !s.file.read(0, signature, 8) ||
      !std::equal(kSignature.begin(), kSignature.end(), signature))
    return std::nullopt;

  std::size_t at = kSignature.size(), compressed = 0;
  int colour_type = -1;
  bool seen_header = false, seen_end = false;
  std::uint8_t chunk[8 + 13 + 4];  // a header, and the most of a chunk read whole
  while (at + 12 <= size) {
    if (!s.file.read(at, chunk, 8)) return std::nullopt;
    const std::uint32_t length = load_be32(chunk);
    const std::uint8_t* type = chunk + 4;
    if (length > size - at - 12) return std::nullopt;
    const bool critical = !(type[0] & 0x20);
    if (std::memcmp(type, "IHDR", 4) == 0 || std::memcmp(type, "IEND", 4) == 0) {
      if (length > 13 || !s.file.read(at + 8, chunk + 8, length + 4) ||
          crc32_gzip_refl(0, type, length + 4) != load_be32(chunk + 8 + length))
        return std::nullopt;
    }
    const std::uint8_t* payload = chunk + 8;
    if (std::memcmp(type, "IHDR", 4) == 0) {
      if (length != 13) return std::nullopt;
      s.width = load_be32(payload);
      s.height = load_be32(payload + 4);
      s.bit_depth = payload[8];
      colour_type = payload[9];
      if (payload[10] != 0 || payload[11] != 0 || payload[12] != 0)
        return std::nullopt;  // interlaced or unknown
      seen_header = true;
    } else if (std::memcmp(type, "IDAT", 4) == 0) {
      s.idat.push_back({at + 8, length});
      compressed += length;
    } else if (std::memcmp(type, "tRNS", 4) == 0 || std::memcmp(type, "PLTE", 4) == 0) {
      return std::nullopt;  // transparency or palette: OpenCV's job
    } else if (std::memcmp(type, "IEND", 4) == 0) {
      seen_end = true;
      break;
    } else if (critical) {
      return std::nullopt;
    }
    at += 12 + length;
  }
  if (!seen_header || !seen_end || s.idat.empty() || (s.bit_depth != 8 && s.bit_depth != 16) ||
      (colour_type != 0 && colour_type != 2) || s.width == 0 || s.height == 0 ||
      std::uint64_t{s.width} * s.height > kMaxPixels)
    return std::nullopt;
  s.channels = colour_type == 2 ? 3 : 1;
  s.bpp = static_cast<std::size_t>(s.channels) * (s.bit_depth / 8);
  s.row_bytes = s.bpp * s.width;
  const std::size_t raw_size = s.height * (s.row_bytes + 1);
  // Deflate expands at most 1032:1; a tiny file claiming a huge image is
  // damaged or hostile and must not get a huge buffer.
  if (compressed * 1032 < raw_size) return std::nullopt;
  // The IDAT payloads are one zlib stream split across chunks; ISA-L
  // inflates it a batch of rows at a time into a small buffer (no image-sized
  // one), checking the Adler-32 at the end.
  isal_inflate_init(&s.inflater);
  s.inflater.crc_flag = ISAL_ZLIB;
  s.above.assign(s.row_bytes, 0);
  return Reader(std::move(state));
}

cv::Size Reader::size() const {
  return {static_cast<int>(state_->width), static_cast<int>(state_->height)};
}

int Reader::type() const {
  return CV_MAKETYPE(state_->bit_depth == 8 ? CV_8U : CV_16U, state_->channels);
}

bool Reader::read(cv::Mat& rows) {
  State& s = *state_;
  if (rows.type() != type() || rows.cols != static_cast<int>(s.width) ||
      s.rows_read + static_cast<std::uint32_t>(rows.rows) > s.height)
    return false;
  const std::size_t stride = s.row_bytes + 1;
  const auto batch_rows = std::max<std::size_t>(1, (std::size_t{1} << 20) / stride);
  s.buffer.resize(batch_rows * stride);  // not cleared: inflation writes every byte
  // Rows depend on the row above, so unfiltering runs in order; each row
  // goes to the image as it is done.
  for (int first = 0; first < rows.rows;) {
    const int n = static_cast<int>(std::min<std::size_t>(batch_rows, rows.rows - first));
    if (!s.inflate_into(s.buffer.data(), n * stride)) return false;
    for (int k = 0; k < n; ++k) {
      std::uint8_t* row = s.buffer.data() + k * stride;
      const std::uint8_t* previous = k ? row - s.row_bytes : s.above.data();
      if (!unfilter_row(row[0], row + 1, previous, s.row_bytes, s.bpp)) return false;
      const std::uint8_t* in = row + 1;
      const int r = first + k;
      if (s.bit_depth == 16 && s.channels == 3)
        rgb16_to_bgr(in, rows.ptr<std::uint16_t>(r), rows.cols);
      else if (s.bit_depth == 16)
        grey16_from_be(in, rows.ptr<std::uint16_t>(r), rows.cols);
      else if (s.channels == 3)
        rgb8_to_bgr(in, rows.ptr<std::uint8_t>(r), rows.cols);
      else
        std::memcpy(rows.ptr(r), in, s.row_bytes);
    }
    std::memcpy(s.above.data(), s.buffer.data() + (n - 1) * stride + 1, s.row_bytes);
    first += n;
  }
  s.rows_read += static_cast<std::uint32_t>(rows.rows);
  if (s.rows_read == s.height) {
    s.buffer = {};
    return s.finish();
  }
  return true;
}

std::optional<cv::Mat> read(const fs::path& file) {
  auto reader = Reader::open(file);
  if (!reader) return std::nullopt;
  cv::Mat image(reader->size(), reader->type());
  if (!reader->read(image)) return std::nullopt;
  return image;
}

namespace {

bool can_write_type(int type) {
  return (CV_MAT_DEPTH(type) == CV_8U || CV_MAT_DEPTH(type) == CV_16U) &&
         (CV_MAT_CN(type) == 1 || CV_MAT_CN(type) == 3);
}

}  // namespace

bool can_write(const cv::Mat& image) {
  return !image.empty() && can_write_type(image.type());
}

namespace {

// Writes chunks to a file, computing each chunk's CRC as its bytes go by.
class ChunkWriter {
 public:
  explicit ChunkWriter(const fs::path& file) : file_(std::fopen(file.c_str(), "wb")) {
    if (file_) {
      std::setvbuf(file_.get(), nullptr, _IOFBF, 1 << 20);
      put(kSignature.data(), kSignature.size());
    }
  }
  [[nodiscard]] bool ok() const { return file_ && ok_; }

  void begin(const char* type, std::size_t length) {
    if (length > kMaxChunk) ok_ = false;  // too large for one PNG chunk
    std::uint8_t header[8];
    store_be32(header, static_cast<std::uint32_t>(length));
    std::memcpy(header + 4, type, 4);
    put(header, 8);
    crc_ = crc32_gzip_refl(0, reinterpret_cast<const std::uint8_t*>(type), 4);
  }
  void data(const std::uint8_t* bytes, std::size_t n) {
    if (n == 0) return;
    crc_ = crc32_gzip_refl(crc_, bytes, n);
    put(bytes, n);
  }
  void end() {
    std::uint8_t crc[4];
    store_be32(crc, crc_);
    put(crc, 4);
  }
  void chunk(const char* type, const std::uint8_t* bytes, std::size_t n) {
    begin(type, n);
    data(bytes, n);
    end();
  }
  bool close() {
    if (!file_) return false;
    ok_ = std::fflush(file_.get()) == 0 && ok_;
    ok_ = std::fclose(file_.release()) == 0 && ok_;
    return ok_;
  }

 private:
  void put(const std::uint8_t* bytes, std::size_t n) {
    ok_ = ok_ && file_ && std::fwrite(bytes, 1, n, file_.get()) == n;
  }
  File file_;
  bool ok_ = true;
  std::uint32_t crc_ = 0;
};

// One image row in PNG byte order (RGB, big-endian samples), filter byte first.
void png_row(const cv::Mat& image, int r, std::uint8_t* out) {
  const bool sixteen = image.depth() == CV_16U;
  const int channels = image.channels();
  if (sixteen && channels == 3)
    bgr16_to_rgb_be(image.ptr<std::uint16_t>(r), out, image.cols);
  else if (sixteen)
    grey16_to_be(image.ptr<std::uint16_t>(r), out, image.cols);
  else if (channels == 3)
    rgb8_to_bgr(image.ptr<std::uint8_t>(r), out, image.cols);  // the swap is symmetric
  else
    std::memcpy(out, image.ptr(r), image.cols * image.elemSize());
}

// Level 0: a zlib stream of stored blocks, produced row by row straight
// into one IDAT chunk, so no image-sized buffer is ever allocated.
class StoredRows {
 public:
  StoredRows(ChunkWriter& out, cv::Size size, std::size_t pixel_bytes)
      : out_(out),
        row_bytes_(static_cast<std::size_t>(size.width) * pixel_bytes),
        raw_(static_cast<std::size_t>(size.height) * (row_bytes_ + 1)),
        block_(5 + kBlock),
        row_(row_bytes_ + 1, 0) {  // filter type 0 (none): stored data gains nothing from one
    const std::size_t blocks = std::max<std::size_t>(1, (raw_ + kBlock - 1) / kBlock);
    out_.begin("IDAT", 2 + raw_ + 5 * blocks + 4);
    const std::uint8_t zlib_header[2] = {0x78, 0x01};
    out_.data(zlib_header, 2);
  }

  void rows(const cv::Mat& image) {
    for (int r = 0; r < image.rows; ++r) {
      png_row(image, r, row_.data() + 1);
      for (std::size_t taken = 0; taken < row_.size();) {
        const std::size_t n = std::min(row_.size() - taken, kBlock - filled_);
        std::memcpy(block_.data() + 5 + filled_, row_.data() + taken, n);
        filled_ += n;
        taken += n;
        if (filled_ == kBlock) flush();
      }
    }
  }

  void finish() {
    if (filled_ > 0 || emitted_ < raw_ || raw_ == 0) flush();
    std::uint8_t trailer[4];
    store_be32(trailer, adler_);
    out_.data(trailer, 4);
    out_.end();
  }

 private:
  static constexpr std::size_t kBlock = 65535;  // the most a stored block holds

  void flush() {
    emitted_ += filled_;
    block_[0] = emitted_ == raw_ ? 1 : 0;  // BFINAL on the last block, type 00 (stored)
    block_[1] = static_cast<std::uint8_t>(filled_);
    block_[2] = static_cast<std::uint8_t>(filled_ >> 8);
    block_[3] = static_cast<std::uint8_t>(~filled_);
    block_[4] = static_cast<std::uint8_t>(~filled_ >> 8);
    adler_ = isal_adler32(adler_, block_.data() + 5, filled_);
    out_.data(block_.data(), 5 + filled_);
    filled_ = 0;
  }

  ChunkWriter& out_;
  std::size_t row_bytes_;
  std::size_t raw_;
  std::vector<std::uint8_t> block_;
  std::vector<std::uint8_t> row_;
  std::size_t filled_ = 0;
  std::size_t emitted_ = 0;
  std::uint32_t adler_ = 1;
};

// Level 1 and up: ISA-L's deflate (4x faster than zlib or libdeflate at
// level 1, for the same size), fed rows filtered with "Up" (the cheap filter
// that helps most) and emptied into IDAT chunks as it goes, so neither the
// filtered image nor the compressed one is ever held whole. The compressor
// gets the same batches however the rows arrive, so the bytes do not depend
// on how the image is handed over.
class CompressedRows {
 public:
  CompressedRows(ChunkWriter& out, cv::Size size, std::size_t pixel_bytes, int level)
      : out_(out),
        row_bytes_(static_cast<std::size_t>(size.width) * pixel_bytes),
        // zlib-scale levels onto ISA-L's 1 (fastest) to 3.
        isal_level_(level <= 3   ? 1
                    : level <= 6 ? 2
                                 : 3),
        level_buffer_(isal_level_ == 1   ? ISAL_DEF_LVL1_DEFAULT
                      : isal_level_ == 2 ? ISAL_DEF_LVL2_DEFAULT
                                         : ISAL_DEF_LVL3_DEFAULT),
        chunk_(kChunk),
        above_(row_bytes_, 0),
        row_(row_bytes_) {
    batch_.reserve(kBatch + row_bytes_ + 1);
    isal_deflate_init(&stream_);
    stream_.level = static_cast<std::uint32_t>(isal_level_);
    stream_.level_buf = level_buffer_.data();
    stream_.level_buf_size = static_cast<std::uint32_t>(level_buffer_.size());
    stream_.gzip_flag = IGZIP_ZLIB;
    stream_.flush = NO_FLUSH;
    stream_.next_out = chunk_.data();
    stream_.avail_out = static_cast<std::uint32_t>(kChunk);
  }
  CompressedRows(const CompressedRows&) = delete;  // the stream points into this
  CompressedRows& operator=(const CompressedRows&) = delete;

  Status rows(const cv::Mat& image) {
    for (int r = 0; r < image.rows; ++r) {
      png_row(image, r, row_.data());
      batch_.push_back(2);  // filter type: Up
      const std::size_t at = batch_.size();
      batch_.insert(batch_.end(), row_.begin(), row_.end());
      subtract_row(batch_.data() + at, above_.data(), row_bytes_);
      std::swap(above_, row_);
      if (batch_.size() >= kBatch && !compress(false))
        return std::unexpected(internal_error("png::write: compression failed"));
    }
    return {};
  }

  Status finish() {
    if (!compress(true)) return std::unexpected(internal_error("png::write: compression failed"));
    return {};
  }

 private:
  static constexpr std::size_t kChunk = 1 << 20;  // IDAT payload size
  static constexpr std::size_t kBatch = 1
                                        << 18;  // filtered bytes handed to the compressor at a time

  bool compress(bool last) {
    stream_.next_in = batch_.data();
    stream_.avail_in = static_cast<std::uint32_t>(batch_.size());
    stream_.end_of_stream = last ? 1 : 0;
    do {
      if (isal_deflate(&stream_) != COMP_OK) return false;
      const bool full = stream_.avail_out == 0;
      const bool done = last && stream_.internal_state.state == ZSTATE_END;
      if (full || done) {
        out_.chunk("IDAT", chunk_.data(), kChunk - stream_.avail_out);
        stream_.next_out = chunk_.data();
        stream_.avail_out = static_cast<std::uint32_t>(kChunk);
      }
      if (done) break;
    } while (stream_.avail_in > 0 || (last && stream_.internal_state.state != ZSTATE_END));
    batch_.clear();
    return true;
  }

  ChunkWriter& out_;
  std::size_t row_bytes_;
  int isal_level_;
  std::vector<std::uint8_t> level_buffer_;
  std::vector<std::uint8_t> chunk_;
  std::vector<std::uint8_t> batch_;
  std::vector<std::uint8_t> above_;
  std::vector<std::uint8_t> row_;
  isal_zstream stream_{};
};

void put_be32(std::vector<std::uint8_t>& bytes, std::uint32_t v) {
  std::uint8_t b[4];
  store_be32(b, v);
  bytes.insert(bytes.end(), b, b + 4);
}

// A keyword PNG accepts: 1-79 printable Latin-1 characters (ASCII here).
std::string png_keyword(const std::string& keyword) {
  std::string k;
  for (char c : keyword)
    if (c >= 32 && c <= 126) k += c;
  if (k.empty()) k = "Comment";
  return k.substr(0, 79);
}
bool is_printable_ascii(const std::string& text) {
  return std::all_of(text.begin(), text.end(),
                     [](char c) { return c == '\n' || (c >= 32 && c <= 126); });
}

// The ancillary chunks before IDAT (PNG 1.2 / ISO 15948 section 11.3):
// colour space first, then physical size, then text.
void write_metadata(ChunkWriter& out, const ImageMetadata& metadata) {
  using Space = ImageMetadata::ColourSpace;
  std::vector<std::uint8_t> bytes;
  if (metadata.colour_space == Space::colour) {
    // sRGB, with the gAMA and cHRM that section 11.3.3.5 recommends beside
    // it for decoders that do not know sRGB.
    const std::uint8_t perceptual = 0;
    out.chunk("sRGB", &perceptual, 1);
    put_be32(bytes, 45455);
    out.chunk("gAMA", bytes.data(), bytes.size());
    bytes.clear();
    for (std::uint32_t v : {31270u, 32900u, 64000u, 33000u, 30000u, 60000u, 15000u, 6000u})
      put_be32(bytes, v);
    out.chunk("cHRM", bytes.data(), bytes.size());
    bytes.clear();
  } else if (metadata.colour_space == Space::data) {
    put_be32(bytes, 100000);  // gamma 1.0: the samples are numbers, not light
    out.chunk("gAMA", bytes.data(), bytes.size());
    bytes.clear();
  }
  if (metadata.pixel_size_mm && *metadata.pixel_size_mm > 0) {
    const auto per_metre =
        static_cast<std::uint32_t>(std::lround(1000.0 / *metadata.pixel_size_mm));
    put_be32(bytes, per_metre);
    put_be32(bytes, per_metre);
    bytes.push_back(1);  // unit: the metre
    out.chunk("pHYs", bytes.data(), bytes.size());
    bytes.clear();
  }
  for (const auto& [keyword, text] : metadata.text) {
    const std::string k = png_keyword(keyword);
    bytes.assign(k.begin(), k.end());
    bytes.push_back(0);
    if (is_printable_ascii(text)) {
      bytes.insert(bytes.end(), text.begin(), text.end());
      out.chunk("tEXt", bytes.data(), bytes.size());
    } else {  // UTF-8: iTXt, uncompressed, no language tag
      bytes.insert(bytes.end(), {0, 0, 0, 0});
      bytes.insert(bytes.end(), text.begin(), text.end());
      out.chunk("iTXt", bytes.data(), bytes.size());
    }
    bytes.clear();
  }
}

}  // namespace

struct Writer::State {
  State(const fs::path& path, cv::Size image_size, int image_type, int compression)
      : file(path), size(image_size), type(image_type), level(compression), out(path) {}
  fs::path file;
  cv::Size size;
  int type;
  int level;
  int rows_written = 0;
  ChunkWriter out;
  std::optional<StoredRows> stored;
  std::optional<CompressedRows> compressed;
};

Writer::Writer(std::unique_ptr<State> state) : state_(std::move(state)) {}
Writer::Writer(Writer&&) noexcept = default;
Writer& Writer::operator=(Writer&&) noexcept = default;
Writer::~Writer() = default;

Result<Writer> Writer::open(const fs::path& file, cv::Size size, int type, int level,
                            const ImageMetadata& metadata) {
  if (!can_write_type(type) || size.width <= 0 || size.height <= 0)
    return std::unexpected(internal_error("png::write: unsupported image type"));
  auto state = std::make_unique<State>(file, size, type, level);
  ChunkWriter& out = state->out;
  if (!out.ok())
    return std::unexpected(io_error(file, std::string("cannot create: ") + std::strerror(errno)));
  std::uint8_t header[13];
  store_be32(header, static_cast<std::uint32_t>(size.width));
  store_be32(header + 4, static_cast<std::uint32_t>(size.height));
  header[8] = CV_MAT_DEPTH(type) == CV_16U ? 16 : 8;
  header[9] = CV_MAT_CN(type) == 3 ? 2 : 0;
  header[10] = header[11] = header[12] = 0;
  out.chunk("IHDR", header, sizeof header);
  write_metadata(out, metadata);
  const std::size_t pixel_bytes = CV_ELEM_SIZE(type);
  if (level <= 0)
    state->stored.emplace(out, size, pixel_bytes);
  else
    state->compressed.emplace(out, size, pixel_bytes, level);
  return Writer(std::move(state));
}

Status Writer::write(const cv::Mat& rows) {
  State& s = *state_;
  if (rows.type() != s.type || rows.cols != s.size.width ||
      s.rows_written + rows.rows > s.size.height)
    return std::unexpected(internal_error("png::Writer: rows of the wrong size or type"));
  s.rows_written += rows.rows;
  if (s.stored) {
    s.stored->rows(rows);
    return {};
  }
  return s.compressed->rows(rows);
}

Status Writer::finish() {
  State& s = *state_;
  if (s.rows_written != s.size.height)
    return std::unexpected(internal_error("png::Writer: finished before the last row"));
  if (s.stored) {
    s.stored->finish();
  } else if (auto ok = s.compressed->finish(); !ok) {
    return ok;
  }
  s.out.chunk("IEND", nullptr, 0);
  if (!s.out.close())
    return std::unexpected(io_error(s.file, std::string("cannot write: ") + std::strerror(errno)));
  return {};
}

Status write(const fs::path& file, const cv::Mat& image, int level, const ImageMetadata& metadata) {
  if (!can_write(image))
    return std::unexpected(internal_error("png::write: unsupported image type"));
  auto writer = Writer::open(file, image.size(), image.type(), level, metadata);
  if (!writer) return std::unexpected(writer.error());
  if (auto ok = writer->write(image); !ok) return ok;
  return writer->finish();
}

}  // namespace psrig::formats::png

namespace psrig::formats::png {

std::optional<std::string> chunk_past_end(const fs::path& file) {
  const MappedFile mapped(file);
  const std::uint8_t* data = mapped.data();
  const std::size_t size = mapped.size();
  if (!data || size < kSignature.size() ||
      !std::equal(kSignature.begin(), kSignature.end(), data))
    return std::nullopt;
  for (std::size_t at = kSignature.size(); at + 8 <= size;) {
    const std::uint32_t length = load_be32(data + at);
    if (length > size - at - 8) {
      std::string type(reinterpret_cast<const char*>(data + at + 4), 4);
      for (char& c : type)
        if (!std::isalpha(static_cast<unsigned char>(c))) c = '?';
      return "chunk '" + type + "' at byte " + std::to_string(at) + " declares " +
             std::to_string(length) + " bytes, but the file ends " +
             std::to_string(size - at - 8) + " bytes later (truncated or corrupt)";
    }
    at += std::size_t{12} + length;
  }
  return std::nullopt;
}

}  // namespace psrig::formats::png
