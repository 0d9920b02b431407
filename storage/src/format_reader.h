// The seam between MeshStream and the per-format readers, and typed value decoding
// shared by them (ASCII tokens, raw binary of either byte order, base64, zlib blocks).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <string>
#include <memory>
#include <span>
#include <string_view>
#include <vector>

#include "input.h"
#include "tetrascope/storage/mesh_stream.h"

struct libdeflate_decompressor;

namespace tetrascope::storage::detail {

// VTK cell type ids; readers of other formats translate into these.
enum VtkCellType : uint8_t {
  kVtkVertex = 1, kVtkPolyVertex = 2, kVtkLine = 3, kVtkPolyLine = 4, kVtkTriangle = 5,
  kVtkTriangleStrip = 6, kVtkPolygon = 7, kVtkPixel = 8, kVtkQuad = 9, kVtkTetra = 10,
  kVtkVoxel = 11, kVtkHexahedron = 12, kVtkWedge = 13, kVtkPyramid = 14,
  kVtkQuadraticEdge = 21, kVtkQuadraticTriangle = 22, kVtkQuadraticQuad = 23,
  kVtkQuadraticTetra = 24, kVtkQuadraticHexahedron = 25, kVtkQuadraticWedge = 26,
  kVtkQuadraticPyramid = 27, kVtkBiquadraticQuad = 28, kVtkTriquadraticHexahedron = 29,
  kVtkQuadraticLinearQuad = 30, kVtkQuadraticLinearWedge = 31,
  kVtkBiquadraticQuadraticWedge = 32, kVtkBiquadraticQuadraticHexahedron = 33,
  kVtkBiquadraticTriangle = 34, kVtkCubicLine = 35, kVtkQuadraticPolygon = 36,
  kVtkTriquadraticPyramid = 37, kVtkPolyhedron = 42,
};

// How a cell type turns into a volume: its corner count, or 0 for a cell that is skipped
// (points, lines, surfaces), or -1 for one that cannot be used.
int volume_corner_count(int vtk_type, int node_count);

struct CellBatch {
  std::vector<uint8_t> types;
  std::vector<uint64_t> offsets{0};  // types.size() + 1 entries into nodes
  std::vector<uint32_t> nodes;       // 0-based vertex indices, already range-checked
  uint64_t reduced = 0;              // higher-order cells the reader cut down to their corners
  bool only_tets = true;             // every cell is a 4-vertex tetrahedron
  // Per cell, for the pieces of a polyhedron a reader decomposed: 2 for the first piece, 1 for
  // each further one (the pieces count as one cell, of their whole volume); 0 for a whole
  // cell. Empty: no pieces.
  std::vector<uint8_t> same_cell;
  void clear() {
    reduced = 0;
    only_tets = true;
    types.clear();
    offsets.assign(1, 0);
    nodes.clear();
    same_cell.clear();
  }
  bool continues(size_t cell) const { return !same_cell.empty() && same_cell[cell] == 1; }
  bool piece(size_t cell) const { return !same_cell.empty() && same_cell[cell] != 0; }
  size_t size() const { return types.size(); }
  void push(uint8_t type, std::span<const uint32_t> cell_nodes) {
    only_tets = only_tets && type == kVtkTetra && cell_nodes.size() == 4;
    types.push_back(type);
    nodes.insert(nodes.end(), cell_nodes.begin(), cell_nodes.end());
    offsets.push_back(nodes.size());
  }
  void push(uint8_t type, const uint32_t (&tet)[4]) {
    only_tets = only_tets && type == kVtkTetra;
    types.push_back(type);
    nodes.insert(nodes.end(), tet, tet + 4);
    offsets.push_back(nodes.size());
  }
};

class FormatReader {
 public:
  virtual ~FormatReader() = default;
  // Reads headers, checks that every declared count fits in the file, locates sections.
  virtual MeshHeader index(ReadStats& stats) = 0;
  // The next `count` vertices in file order: xyz interleaved (3 * count, finite), and one
  // array per header attribute (count * components).
  virtual void read_vertices(size_t count, float* xyz, std::span<float* const> attributes,
                             ReadStats& stats) = 0;
  // Appends up to about `max_cells` cells; returns false when no cell is left.
  virtual bool read_cells(CellBatch& batch, size_t max_cells) = 0;
  // Cell data, for a reader whose header lists cell_attributes: the values of the next `count`
  // cells in file order (every cell, volume or not: one tuple each), one array per cell
  // attribute (count * components). Called in step with read_cells.
  virtual void read_cell_values(size_t /*count*/, std::span<float* const> /*values*/, ReadStats& /*stats*/) {}
  // Starts the cells and their values again from the first cell (after a pass that converted
  // cell data to the vertices).
  virtual void rewind_cells() {}
  // The tagged boundary faces met, once read_cells returned false (vertex ids range-checked).
  virtual FaceTags take_face_tags() { return {}; }
};

std::unique_ptr<FormatReader> make_vtk_legacy_reader(std::shared_ptr<InputFile> file);
std::unique_ptr<FormatReader> make_vtu_reader(std::shared_ptr<InputFile> file);
// `time_step`: ReadLimits::time_step (-1: each field's last section)
std::unique_ptr<FormatReader> make_gmsh_reader(std::shared_ptr<InputFile> file, int64_t time_step = -1);
std::unique_ptr<FormatReader> make_tetgen_reader(std::shared_ptr<InputFile> node_file,
                                                 std::shared_ptr<InputFile> ele_file);
std::unique_ptr<FormatReader> make_off_reader(std::shared_ptr<InputFile> file);
std::unique_ptr<FormatReader> make_exodus_reader(const std::filesystem::path& path, const ReadLimits& limits);
std::unique_ptr<FormatReader> make_cgns_reader(const std::filesystem::path& path, const ReadLimits& limits);
std::unique_ptr<FormatReader> make_openfoam_reader(const std::filesystem::path& path, const ReadLimits& limits);

// ---- typed values -------------------------------------------------------------------

// Stores keep coordinates and attributes as 32-bit floats, so a value is judged after that
// conversion: 1e39 is a finite double but an infinite float. Readers refuse a coordinate that
// fails this (a store's bounds would not be finite) and count an attribute value that fails it
// as non-finite (ReadStats::nonfinite_attribute_values), as `info` does.
inline bool to_stored_float(double value, float& out) {
  out = static_cast<float>(value);
  return std::isfinite(out);
}
// "point coordinate 1e+39 is not a finite 32-bit float (magnitude at most 3.4e+38)"
std::string not_a_float_message(std::string_view what, double value);

enum class ScalarType { kInt8, kUInt8, kInt16, kUInt16, kInt32, kUInt32, kInt64, kUInt64, kFloat32, kFloat64 };
size_t scalar_size(ScalarType type);

// Bytes of one encoded array, in order.
class ByteStream {
 public:
  virtual ~ByteStream() = default;
  virtual void read(void* dst, size_t n, std::string_view what) = 0;
  [[noreturn]] virtual void fail(std::string_view what) const = 0;
};

// A bounded window of raw bytes read through a cursor.
class RawBytes final : public ByteStream {
 public:
  RawBytes(std::shared_ptr<const InputFile> file, uint64_t offset, uint64_t limit);
  void read(void* dst, size_t n, std::string_view what) override;
  [[noreturn]] void fail(std::string_view what) const override { cursor_.fail_byte(what); }

 private:
  Cursor cursor_;
  uint64_t left_;
};

// Base64 text (whitespace ignored); padded quanta may be followed by more base64, as when
// VTK encodes a header and its data separately.
class Base64Bytes final : public ByteStream {
 public:
  Base64Bytes(std::shared_ptr<const InputFile> file, uint64_t offset, uint64_t line);
  void read(void* dst, size_t n, std::string_view what) override;
  [[noreturn]] void fail(std::string_view what) const override { cursor_.fail(what); }

 private:
  Cursor cursor_;
  uint8_t pending_[3]{};
  int pending_count_ = 0;
  int pending_pos_ = 0;
};

// VTK's vtkZLibDataCompressor framing: a header [blocks, block size, last block size,
// compressed sizes...] (UInt32 or UInt64) and then the deflated blocks.
// Blocks are inflated with libdeflate, several at a time and on two threads.
class ZlibBlocks final : public ByteStream {
 public:
  static constexpr uint64_t kGroupBytes = 1 << 20;  // inflate about this much output at once
  // `what` names the data in errors
  ZlibBlocks(std::unique_ptr<ByteStream> inner, bool header_uint64, bool little_endian,
             uint64_t expected_bytes, uint64_t file_size, std::string_view what = "compressed data");
  ~ZlibBlocks() override;
  void read(void* dst, size_t n, std::string_view what) override;
  [[noreturn]] void fail(std::string_view what) const override {
    inner_->fail(what);
    __builtin_unreachable();
  }

 private:
  void next_group();
  uint64_t block_bytes(size_t block) const;
  std::unique_ptr<ByteStream> inner_;
  std::vector<uint64_t> compressed_sizes_;
  uint64_t block_size_ = 0, last_block_size_ = 0;
  size_t block_ = 0;
  std::vector<uint8_t> compressed_, block_data_;
  size_t block_pos_ = 0;
  libdeflate_decompressor* inflaters_[2] = {nullptr, nullptr};
};

class ValueStream {
 public:
  virtual ~ValueStream() = default;
  // n values as float. finite_only: a NaN or infinity fails; otherwise they are counted
  // and the count returned.
  virtual uint64_t read_float(float* out, size_t n, bool finite_only, std::string_view what) = 0;
  virtual void read_int(int64_t* out, size_t n, std::string_view what) = 0;
  [[noreturn]] virtual void fail(std::string_view what) const = 0;
};

class AsciiValues final : public ValueStream {
 public:
  // `token_end`: a character that ends a value besides white space ('<' inside XML)
  AsciiValues(std::shared_ptr<const InputFile> file, uint64_t offset, uint64_t line, char token_end = ' ')
      : cursor_(std::move(file), offset, line) {
    cursor_.end_tokens_at(token_end);
  }
  uint64_t read_float(float* out, size_t n, bool finite_only, std::string_view what) override;
  void read_int(int64_t* out, size_t n, std::string_view what) override;
  [[noreturn]] void fail(std::string_view what) const override { cursor_.fail(what); }

 private:
  Cursor cursor_;
};

class BinaryValues final : public ValueStream {
 public:
  BinaryValues(std::unique_ptr<ByteStream> bytes, ScalarType type, bool little_endian)
      : bytes_(std::move(bytes)), type_(type), little_endian_(little_endian) {}
  uint64_t read_float(float* out, size_t n, bool finite_only, std::string_view what) override;
  void read_int(int64_t* out, size_t n, std::string_view what) override;
  [[noreturn]] void fail(std::string_view what) const override {
    bytes_->fail(what);
    __builtin_unreachable();
  }

 private:
  const uint8_t* fetch(size_t n, std::string_view what);
  std::unique_ptr<ByteStream> bytes_;
  ScalarType type_;
  bool little_endian_;
  std::vector<uint8_t> scratch_;
  std::vector<double> tmp_;
};

// Integers read ahead in blocks from a ValueStream that holds exactly `total` of them.
class BufferedInts {
 public:
  static constexpr size_t kBlock = 1 << 15;
  BufferedInts() = default;
  BufferedInts(ValueStream* stream, uint64_t total) : stream_(stream), left_(total) {}
  uint64_t remaining() const { return left_ + (end_ - pos_); }
  int64_t next(std::string_view what) {
    if (pos_ == end_) fill(1, what);
    return buffer_[pos_++];
  }
  // The next `n` values (n <= remaining()) without consuming them; valid until the next call.
  std::span<const int64_t> peek(size_t n, std::string_view what) {
    if (end_ - pos_ < n) fill(n, what);
    return {buffer_.get() + pos_, n};
  }
  void consume(size_t n) { pos_ += n; }
  ValueStream& stream() { return *stream_; }

 private:
  // Makes at least `n` values available from pos_, reading at least a block.
  void fill(size_t n, std::string_view what) {
    size_t have = end_ - pos_;
    size_t more = static_cast<size_t>(std::min<uint64_t>(left_, std::max(n - have, kBlock)));
    if (have + more < n || more == 0) stream_->fail("more values needed than declared for " + std::string(what));
    if (have + more > capacity_) {  // uninitialised storage: every slot is written before it is read
      std::unique_ptr<int64_t[]> bigger(new int64_t[have + more]);
      std::copy(buffer_.get() + pos_, buffer_.get() + end_, bigger.get());
      buffer_ = std::move(bigger);
      capacity_ = have + more;
    } else {
      std::copy(buffer_.get() + pos_, buffer_.get() + end_, buffer_.get());
    }
    stream_->read_int(buffer_.get() + have, more, what);
    left_ -= more;
    pos_ = 0;
    end_ = have + more;
  }
  ValueStream* stream_ = nullptr;
  uint64_t left_ = 0;
  std::unique_ptr<int64_t[]> buffer_;
  size_t capacity_ = 0, pos_ = 0, end_ = 0;
};

// Reads one cell of `node_count` vertex ids from `connectivity` and appends it, checking every
// id against `vertex_count` and the type against its vertex count; `cell` numbers the errors.
void append_cell(CellBatch& batch, BufferedInts& connectivity, int64_t node_count, int64_t type, uint64_t cell,
                 uint64_t vertex_count, ValueStream& type_stream, std::vector<uint32_t>& scratch);

// Appends up to `count` tetrahedra from the next `count` cells when they are all 4-vertex
// tets with in-range indices; otherwise appends nothing and returns false, and the caller
// reads them one by one (which finds and reports any problem). `connectivity` holds
// `stride` values a cell: the vertex count first when stride is 5 (legacy VTK), else 4.
bool append_tet_run(std::span<const int64_t> types, std::span<const int64_t> connectivity, size_t stride,
                    uint64_t vertex_count, CellBatch& batch);

// Converts `count` values of `type` stored at `src` (given byte order) to double / int64.
void decode_values(const uint8_t* src, size_t count, ScalarType type, bool little_endian, double* out);
void decode_values(const uint8_t* src, size_t count, ScalarType type, bool little_endian, int64_t* out);

// Fails unless `needed` bytes (count * per_item) fit in what is left of the file; guards
// allocations driven by untrusted counts. Overflow-safe.
void check_fits(const Cursor& cursor, uint64_t count, uint64_t bytes_per_item, std::string_view what);

}  // namespace tetrascope::storage::detail
