// Typed value decoding for the mesh readers: ASCII tokens, raw binary of either byte
// order, base64 text, and VTK's zlib block framing. All sizes are checked against the
// file before anything is allocated.
#include <libdeflate.h>

#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <new>
#include <thread>

#include "format_reader.h"

namespace tetrascope::storage::detail {

size_t scalar_size(ScalarType type) {
  switch (type) {
    case ScalarType::kInt8: case ScalarType::kUInt8: return 1;
    case ScalarType::kInt16: case ScalarType::kUInt16: return 2;
    case ScalarType::kInt32: case ScalarType::kUInt32: case ScalarType::kFloat32: return 4;
    case ScalarType::kInt64: case ScalarType::kUInt64: case ScalarType::kFloat64: return 8;
  }
  return 1;
}


void check_fits(const Cursor& cursor, uint64_t count, uint64_t bytes_per_item, std::string_view what) {
  uint64_t left = cursor.remaining();
  if (bytes_per_item != 0 && count > left / bytes_per_item) {
    cursor.fail(std::string(what) + ": " + std::to_string(count) + " declared, but only " +
                std::to_string(left) + " bytes are left in the file");
  }
}

int volume_corner_count(int type, int node_count) {
  switch (type) {
    case kVtkTetra: return node_count == 4 ? 4 : -1;
    case kVtkVoxel: case kVtkHexahedron: return node_count == 8 ? 8 : -1;
    case kVtkWedge: return node_count == 6 ? 6 : -1;
    case kVtkPyramid: return node_count == 5 ? 5 : -1;
    case kVtkQuadraticTetra: return node_count == 10 ? 4 : -1;
    case kVtkQuadraticHexahedron: return node_count == 20 ? 8 : -1;
    case kVtkTriquadraticHexahedron: return node_count == 27 ? 8 : -1;
    case kVtkBiquadraticQuadraticHexahedron: return node_count == 24 ? 8 : -1;
    case kVtkQuadraticWedge: return node_count == 15 ? 6 : -1;
    case kVtkQuadraticLinearWedge: return node_count == 12 ? 6 : -1;
    case kVtkBiquadraticQuadraticWedge: return node_count == 18 ? 6 : -1;
    case kVtkQuadraticPyramid: return node_count == 13 ? 5 : -1;
    case kVtkTriquadraticPyramid: return node_count == 19 ? 5 : -1;
    case kVtkVertex: case kVtkPolyVertex: case kVtkLine: case kVtkPolyLine: case kVtkTriangle:
    case kVtkTriangleStrip: case kVtkPolygon: case kVtkPixel: case kVtkQuad:
    case kVtkQuadraticEdge: case kVtkQuadraticTriangle: case kVtkQuadraticQuad:
    case kVtkBiquadraticQuad: case kVtkQuadraticLinearQuad: case kVtkBiquadraticTriangle:
    case kVtkCubicLine: case kVtkQuadraticPolygon:
      return 0;
    default: return -1;
  }
}

void append_cell(CellBatch& batch, BufferedInts& connectivity, int64_t node_count, int64_t type, uint64_t cell,
                 uint64_t vertex_count, ValueStream& type_stream, std::vector<uint32_t>& scratch) {
  scratch.resize(static_cast<size_t>(node_count));
  for (int64_t k = 0; k < node_count; ++k) {
    int64_t v = connectivity.next("cell connectivity");
    if (v < 0 || static_cast<uint64_t>(v) >= vertex_count) {
      connectivity.stream().fail("cell " + std::to_string(cell) + ": vertex id " + std::to_string(v) + " out of range (the mesh has " +
                                 std::to_string(vertex_count) + " points)");
    }
    scratch[static_cast<size_t>(k)] = static_cast<uint32_t>(v);
  }
  if (type < 0 || type > 255 || volume_corner_count(static_cast<int>(type), static_cast<int>(std::min<int64_t>(node_count, 1 << 20))) < 0) {
    type_stream.fail("cell " + std::to_string(cell) + ": unsupported cell type " + std::to_string(type) + " with " +
                     std::to_string(node_count) + " vertices");
  }
  batch.push(static_cast<uint8_t>(type), scratch);
}

bool append_tet_run(std::span<const int64_t> types, std::span<const int64_t> connectivity, size_t stride,
                    uint64_t vertex_count, CellBatch& batch) {
  const size_t count = types.size();
  bool ok = true;
  for (size_t c = 0; c < count; ++c) ok &= types[c] == kVtkTetra;
  if (stride == 5) {
    for (size_t c = 0; c < count; ++c) ok &= connectivity[5 * c] == 4;
  }
  const size_t skip = stride == 5 ? 1 : 0;
  uint64_t bad = 0;
  for (size_t c = 0; c < count; ++c) {
    for (size_t k = 0; k < 4; ++k) bad |= static_cast<uint64_t>(connectivity[stride * c + skip + k]) >= vertex_count;
  }
  if (!ok || bad) return false;
  size_t base = batch.nodes.size();
  batch.nodes.resize(base + 4 * count);
  uint32_t* out = batch.nodes.data() + base;
  for (size_t c = 0; c < count; ++c) {
    for (size_t k = 0; k < 4; ++k) out[4 * c + k] = static_cast<uint32_t>(connectivity[stride * c + skip + k]);
  }
  batch.types.insert(batch.types.end(), count, static_cast<uint8_t>(kVtkTetra));
  for (size_t c = 0; c < count; ++c) batch.offsets.push_back(base + 4 * (c + 1));
  return true;
}

// ---- raw -----------------------------------------------------------------------------

RawBytes::RawBytes(std::shared_ptr<const InputFile> file, uint64_t offset, uint64_t limit)
    : cursor_(std::move(file), offset), left_(limit) {}

void RawBytes::read(void* dst, size_t n, std::string_view what) {
  if (n > left_) cursor_.fail_byte("data ends early in " + std::string(what));
  cursor_.read(dst, n, what);
  left_ -= n;
}

// ---- base64 --------------------------------------------------------------------------

namespace {
constexpr int8_t kBase64Invalid = -1, kBase64Space = -2, kBase64Pad = -3;
struct Base64Table {
  int8_t value[256];
  constexpr Base64Table() : value() {
    for (int i = 0; i < 256; ++i) value[i] = kBase64Invalid;
    const char* letters = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    for (int i = 0; i < 64; ++i) value[static_cast<unsigned char>(letters[i])] = static_cast<int8_t>(i);
    value[static_cast<unsigned char>(' ')] = value[static_cast<unsigned char>('\n')] = kBase64Space;
    value[static_cast<unsigned char>('\r')] = value[static_cast<unsigned char>('\t')] = kBase64Space;
    value[static_cast<unsigned char>('=')] = kBase64Pad;
  }
};
constexpr Base64Table kBase64;
}  // namespace

Base64Bytes::Base64Bytes(std::shared_ptr<const InputFile> file, uint64_t offset, uint64_t line)
    : cursor_(std::move(file), offset, line) {}

void Base64Bytes::read(void* dst, size_t n, std::string_view what) {
  uint8_t* out = static_cast<uint8_t*>(dst);
  while (n > 0) {
    if (pending_pos_ < pending_count_) {
      *out++ = pending_[pending_pos_++];
      --n;
      continue;
    }
    // decode the next quantum of 4 characters
    int values[4];
    int got = 0, pads = 0;
    while (got + pads < 4) {
      int c = cursor_.peek();
      if (c < 0) cursor_.fail("base64 data ends early in " + std::string(what));
      int8_t v = kBase64.value[c];
      if (v == kBase64Space) {
        cursor_.skip_whitespace();
        continue;
      }
      char ch = static_cast<char>(c);
      if (v == kBase64Invalid) {
        cursor_.fail("invalid base64 character " + quote_text(std::string_view(&ch, 1)) + " in " + std::string(what));
      }
      cursor_.skip(1, what);
      if (v == kBase64Pad) {
        if (got < 2) cursor_.fail("misplaced base64 padding in " + std::string(what));
        ++pads;
      } else {
        if (pads > 0) cursor_.fail("base64 data after padding in " + std::string(what));
        values[got++] = v;
      }
    }
    uint32_t bits = 0;
    for (int i = 0; i < 4; ++i) bits = (bits << 6) | static_cast<uint32_t>(i < got ? values[i] : 0);
    pending_[0] = static_cast<uint8_t>(bits >> 16);
    pending_[1] = static_cast<uint8_t>(bits >> 8);
    pending_[2] = static_cast<uint8_t>(bits);
    pending_count_ = got - 1;
    pending_pos_ = 0;
  }
}

// ---- zlib ----------------------------------------------------------------------------

namespace {
uint64_t load_header_item(const uint8_t* p, bool uint64, bool little_endian) {
  uint64_t v = 0;
  size_t size = uint64 ? 8 : 4;
  for (size_t i = 0; i < size; ++i) {
    size_t k = little_endian ? size - 1 - i : i;
    v = (v << 8) | p[k];
  }
  return v;
}
}  // namespace

ZlibBlocks::ZlibBlocks(std::unique_ptr<ByteStream> inner, bool header_uint64, bool little_endian,
                       uint64_t expected_bytes, uint64_t file_size, std::string_view what)
    : inner_(std::move(inner)) {
  const size_t item = header_uint64 ? 8 : 4;
  uint8_t head[24];
  inner_->read(head, 3 * item, "compression header");
  uint64_t blocks = load_header_item(head, header_uint64, little_endian);
  block_size_ = load_header_item(head + item, header_uint64, little_endian);
  last_block_size_ = load_header_item(head + 2 * item, header_uint64, little_endian);
  if (blocks > file_size / item) {
    inner_->fail("compression header claims " + std::to_string(blocks) + " blocks, more than the file can hold");
  }
  if (blocks > 0 && (block_size_ == 0 || block_size_ > (uint64_t{1} << 31))) {
    inner_->fail("compression header has an invalid block size " + std::to_string(block_size_));
  }
  if (last_block_size_ > block_size_) inner_->fail("compression header: last block larger than the block size");
  uint64_t total = 0;
  if (blocks > 0) {
    total = (blocks - 1) * block_size_ + (last_block_size_ == 0 ? block_size_ : last_block_size_);
  }
  if (total != expected_bytes) {
    inner_->fail(std::string(what) + " holds " + std::to_string(total) + " bytes, expected " +
                 std::to_string(expected_bytes));
  }
  compressed_sizes_.resize(static_cast<size_t>(blocks));
  std::vector<uint8_t> sizes(static_cast<size_t>(blocks) * item);
  inner_->read(sizes.data(), sizes.size(), "compression header");
  for (size_t b = 0; b < compressed_sizes_.size(); ++b) {
    compressed_sizes_[b] = load_header_item(sizes.data() + b * item, header_uint64, little_endian);
    if (compressed_sizes_[b] > file_size) inner_->fail("compressed block size larger than the file");
  }
}

ZlibBlocks::~ZlibBlocks() {
  for (libdeflate_decompressor* d : inflaters_) {
    if (d) libdeflate_free_decompressor(d);
  }
}

uint64_t ZlibBlocks::block_bytes(size_t block) const {
  return (block + 1 == compressed_sizes_.size() && last_block_size_ != 0) ? last_block_size_ : block_size_;
}

void ZlibBlocks::next_group() {
  if (block_ >= compressed_sizes_.size()) inner_->fail("compressed data ends early");
  // Consecutive blocks up to kGroupBytes of output, read in one go and inflated in two halves.
  size_t first = block_, last = block_;
  uint64_t out_bytes = 0, in_bytes = 0;
  std::vector<uint64_t> in_at{0}, out_at{0};
  while (last < compressed_sizes_.size() && (last == first || out_bytes + block_bytes(last) <= kGroupBytes)) {
    out_bytes += block_bytes(last);
    in_bytes += compressed_sizes_[last];
    in_at.push_back(in_bytes);
    out_at.push_back(out_bytes);
    ++last;
  }
  compressed_.resize(static_cast<size_t>(in_bytes));
  inner_->read(compressed_.data(), compressed_.size(), "compressed block");
  block_data_.resize(static_cast<size_t>(out_bytes));
  for (auto*& d : inflaters_) {
    if (!d) d = libdeflate_alloc_decompressor();
    if (!d) throw std::bad_alloc();
  }
  const size_t count = last - first;
  auto inflate = [&](size_t begin, size_t end, libdeflate_decompressor* d) -> size_t {  // returns the first bad block or end
    for (size_t b = begin; b < end; ++b) {
      size_t produced = 0;
      libdeflate_result rc = libdeflate_zlib_decompress(d, compressed_.data() + in_at[b], in_at[b + 1] - in_at[b],
                                                        block_data_.data() + out_at[b], out_at[b + 1] - out_at[b], &produced);
      if (rc != LIBDEFLATE_SUCCESS || produced != out_at[b + 1] - out_at[b]) return b;
    }
    return end;
  };
  size_t bad_first = count, bad_second = count;
  if (count >= 4) {
    std::thread helper([&] { bad_second = inflate(count / 2, count, inflaters_[1]); });
    bad_first = inflate(0, count / 2, inflaters_[0]);
    helper.join();
    if (bad_first == count / 2) bad_first = count;
  } else {
    bad_first = inflate(0, count, inflaters_[0]);
  }
  size_t bad = std::min(bad_first, bad_second);
  if (bad < count) inner_->fail("compressed block " + std::to_string(first + bad) + " is corrupt (inflate failed or wrong size)");
  block_ = last;
  block_pos_ = 0;
}

void ZlibBlocks::read(void* dst, size_t n, std::string_view) {
  uint8_t* out = static_cast<uint8_t*>(dst);
  while (n > 0) {
    if (block_pos_ >= block_data_.size()) next_group();
    size_t take = std::min(n, block_data_.size() - block_pos_);
    std::memcpy(out, block_data_.data() + block_pos_, take);
    block_pos_ += take;
    out += take;
    n -= take;
  }
}

// ---- values --------------------------------------------------------------------------

std::string not_a_float_message(std::string_view what, double value) {
  char text[96];
  std::snprintf(text, sizeof text, " %.9g is not a finite 32-bit float (magnitude at most %.7g)", value,
                static_cast<double>(std::numeric_limits<float>::max()));
  return std::string(what) + text;
}

uint64_t AsciiValues::read_float(float* out, size_t n, bool finite_only, std::string_view what) {
  uint64_t nonfinite = 0;
  for (size_t i = 0; i < n; ++i) {
    double v = cursor_.parse_double(what);
    if (!std::isfinite(v) || std::fabs(v) > std::numeric_limits<float>::max()) {
      if (finite_only) cursor_.fail(std::string(what) + " is not a finite number");
      ++nonfinite;
    }
    out[i] = static_cast<float>(v);
  }
  return nonfinite;
}

void AsciiValues::read_int(int64_t* out, size_t n, std::string_view what) {
  for (size_t i = 0; i < n; ++i) out[i] = cursor_.parse_int<int64_t>(what);
}

const uint8_t* BinaryValues::fetch(size_t n, std::string_view what) {
  size_t bytes = n * scalar_size(type_);
  if (scratch_.size() < bytes) scratch_.resize(bytes);
  bytes_->read(scratch_.data(), bytes, what);
  return scratch_.data();
}

namespace {
template <typename T>
T load(const uint8_t* p, bool little_endian) {
  T v;
  std::memcpy(&v, p, sizeof(T));
  if (little_endian != (std::endian::native == std::endian::little)) {
    if constexpr (sizeof(T) == 2) {
      uint16_t u;
      std::memcpy(&u, &v, 2);
      u = __builtin_bswap16(u);
      std::memcpy(&v, &u, 2);
    } else if constexpr (sizeof(T) == 4) {
      uint32_t u;
      std::memcpy(&u, &v, 4);
      u = __builtin_bswap32(u);
      std::memcpy(&v, &u, 4);
    } else if constexpr (sizeof(T) == 8) {
      uint64_t u;
      std::memcpy(&u, &v, 8);
      u = __builtin_bswap64(u);
      std::memcpy(&v, &u, 8);
    }
  }
  return v;
}

template <typename Out>
void decode_all(const uint8_t* src, size_t count, ScalarType type, bool le, Out* out) {
  switch (type) {
    case ScalarType::kInt8: for (size_t i = 0; i < count; ++i) out[i] = static_cast<Out>(load<int8_t>(src + i, le)); break;
    case ScalarType::kUInt8: for (size_t i = 0; i < count; ++i) out[i] = static_cast<Out>(load<uint8_t>(src + i, le)); break;
    case ScalarType::kInt16: for (size_t i = 0; i < count; ++i) out[i] = static_cast<Out>(load<int16_t>(src + 2 * i, le)); break;
    case ScalarType::kUInt16: for (size_t i = 0; i < count; ++i) out[i] = static_cast<Out>(load<uint16_t>(src + 2 * i, le)); break;
    case ScalarType::kInt32: for (size_t i = 0; i < count; ++i) out[i] = static_cast<Out>(load<int32_t>(src + 4 * i, le)); break;
    case ScalarType::kUInt32: for (size_t i = 0; i < count; ++i) out[i] = static_cast<Out>(load<uint32_t>(src + 4 * i, le)); break;
    case ScalarType::kInt64: for (size_t i = 0; i < count; ++i) out[i] = static_cast<Out>(load<int64_t>(src + 8 * i, le)); break;
    case ScalarType::kUInt64:
      for (size_t i = 0; i < count; ++i) {
        uint64_t v = load<uint64_t>(src + 8 * i, le);
        out[i] = v > static_cast<uint64_t>(std::numeric_limits<int64_t>::max()) ? static_cast<Out>(-1) : static_cast<Out>(v);
      }
      break;
    case ScalarType::kFloat32:
      for (size_t i = 0; i < count; ++i) {
        if constexpr (std::is_integral_v<Out>) {
          float f = load<float>(src + 4 * i, le);
          out[i] = (std::isfinite(f) && std::fabs(f) < 9e18f) ? static_cast<Out>(f) : static_cast<Out>(-1);
        } else {
          out[i] = static_cast<Out>(load<float>(src + 4 * i, le));
        }
      }
      break;
    case ScalarType::kFloat64:
      for (size_t i = 0; i < count; ++i) {
        if constexpr (std::is_integral_v<Out>) {
          double f = load<double>(src + 8 * i, le);
          out[i] = (std::isfinite(f) && std::fabs(f) < 9e18) ? static_cast<Out>(f) : static_cast<Out>(-1);
        } else {
          out[i] = static_cast<Out>(load<double>(src + 8 * i, le));
        }
      }
      break;
  }
}
}  // namespace

void decode_values(const uint8_t* src, size_t count, ScalarType type, bool le, double* out) {
  decode_all(src, count, type, le, out);
}
void decode_values(const uint8_t* src, size_t count, ScalarType type, bool le, int64_t* out) {
  decode_all(src, count, type, le, out);
}

uint64_t BinaryValues::read_float(float* out, size_t n, bool finite_only, std::string_view what) {
  constexpr size_t kStep = 1 << 15;
  uint64_t nonfinite = 0;
  if (type_ != ScalarType::kFloat32 && tmp_.size() < kStep) tmp_.resize(kStep);
  double* tmp = tmp_.data();
  for (size_t done = 0; done < n; done += kStep) {
    size_t m = std::min(kStep, n - done);
    const uint8_t* src = fetch(m, what);
    if (type_ == ScalarType::kFloat32) {
      for (size_t i = 0; i < m; ++i) out[done + i] = load<float>(src + 4 * i, little_endian_);
    } else {
      decode_values(src, m, type_, little_endian_, tmp);
      for (size_t i = 0; i < m; ++i) out[done + i] = static_cast<float>(tmp[i]);
    }
    for (size_t i = 0; i < m; ++i) {
      if (!std::isfinite(out[done + i])) {
        if (finite_only) bytes_->fail(std::string(what) + " is not a finite number");
        ++nonfinite;
      }
    }
  }
  return nonfinite;
}

void BinaryValues::read_int(int64_t* out, size_t n, std::string_view what) {
  constexpr size_t kStep = 1 << 15;
  for (size_t done = 0; done < n; done += kStep) {
    size_t m = std::min(kStep, n - done);
    decode_values(fetch(m, what), m, type_, little_endian_, out + done);
  }
}

}  // namespace tetrascope::storage::detail
