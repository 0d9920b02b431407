// VTK legacy unstructured grids (.vtk), ASCII and BINARY (big-endian), file versions up to
// 5.1 (OFFSETS/CONNECTIVITY cells); triangles and quads beside the volume cells tagged by a
// region-id CELL_DATA array become boundary face tags (region_tags.h). Format: "VTK File
// Formats", VTK User's Guide ch. 19.
#include <algorithm>
#include <cctype>
#include <functional>
#include <optional>

#include "format_reader.h"
#include "region_tags.h"

namespace tetrascope::storage::detail {
namespace {

std::string upper(std::string_view s) {
  std::string u(s);
  for (char& c : u) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return u;
}

// Where an array's values start and how they are encoded.
struct ArrayLocation {
  uint64_t offset = 0;
  uint64_t line = 1;
  ScalarType type = ScalarType::kFloat32;
  uint64_t values = 0;
};

struct PointArray {
  AttributeInfo info;
  ArrayLocation location;
};

// `count` tuples of an array. A NaN or infinite value is counted, except in a tensor: there it
// fails, naming the line (ASCII) or byte (BINARY), since no eigen-analysis can use it.
uint64_t read_array(ValueStream& values, float* out, size_t count, const AttributeInfo& info) {
  if (info.kind == AttributeKind::kTensor) return values.read_float(out, count * info.components, true, "tensor '" + info.name + "' value");
  return values.read_float(out, count * info.components, false, info.name);
}

class VtkLegacyReader final : public FormatReader {
 public:
  explicit VtkLegacyReader(std::shared_ptr<InputFile> file) : file_(std::move(file)), cursor_(file_) {}

  MeshHeader index(ReadStats& stats) override;
  void read_vertices(size_t count, float* xyz, std::span<float* const> attributes, ReadStats& stats) override;
  bool read_cells(CellBatch& batch, size_t max_cells) override;
  void read_cell_values(size_t count, std::span<float* const> values, ReadStats& stats) override;
  void rewind_cells() override;
  FaceTags take_face_tags() override;

 private:
  std::optional<ScalarType> parse_type(std::string_view name) const;
  // Skips `values` values of `type` (binary: by size; ASCII: by token) and returns where they began.
  ArrayLocation skip_array(uint64_t values, std::string_view type_name, std::string_view what);
  void read_attribute_section(bool point_data, uint64_t tuples, ReadStats& stats);
  // A FIELD block. With `tuples`, every array must have that many and is passed to `keep`;
  // without, arrays of any size are skipped.
  void read_field(std::optional<uint64_t> tuples,
                  const std::function<void(std::string, uint32_t, const ArrayLocation&)>& keep);
  // VTK 9 writes METADATA / INFORMATION blocks ended by an empty line.
  void skip_metadata();
  std::unique_ptr<ValueStream> stream_at(const ArrayLocation& location) const;

  std::shared_ptr<InputFile> file_;
  Cursor cursor_;
  bool binary_ = false;
  MeshHeader header_;
  std::optional<ArrayLocation> points_, cells_, offsets_, connectivity_, cell_types_;
  uint64_t cell_count_ = 0;
  std::vector<PointArray> point_arrays_, cell_arrays_;

  // vertex pass
  std::unique_ptr<ValueStream> point_values_;
  std::vector<std::unique_ptr<ValueStream>> attribute_values_;
  // cell pass
  bool cells_started_ = false;
  uint64_t cells_read_ = 0;
  std::unique_ptr<ValueStream> cell_stream_, offset_stream_, type_stream_;
  BufferedInts cell_ints_, offset_ints_, type_ints_;
  int64_t previous_offset_ = 0;
  static constexpr uint64_t kTetRun = 1024;
  size_t slow_cells_ = 0;  // cells left to read one by one after a run that was not plain tets
  std::vector<uint32_t> cell_nodes_;
  std::vector<std::unique_ptr<ValueStream>> cell_values_;
  std::optional<size_t> region_array_;  // the cell array of region ids, if any
  SurfaceRegions surfaces_;
};

std::optional<ScalarType> VtkLegacyReader::parse_type(std::string_view name) const {
  std::string t = upper(name);
  if (t == "UNSIGNED_CHAR") return ScalarType::kUInt8;
  if (t == "CHAR") return ScalarType::kInt8;
  if (t == "UNSIGNED_SHORT") return ScalarType::kUInt16;
  if (t == "SHORT") return ScalarType::kInt16;
  if (t == "UNSIGNED_INT") return ScalarType::kUInt32;
  if (t == "INT") return ScalarType::kInt32;
  if (t == "UNSIGNED_LONG" || t == "VTKTYPEUINT64") return ScalarType::kUInt64;
  if (t == "LONG" || t == "VTKTYPEINT64" || t == "VTKIDTYPE") return ScalarType::kInt64;
  if (t == "FLOAT") return ScalarType::kFloat32;
  if (t == "DOUBLE") return ScalarType::kFloat64;
  return std::nullopt;
}

ArrayLocation VtkLegacyReader::skip_array(uint64_t values, std::string_view type_name, std::string_view what) {
  ArrayLocation location;
  location.values = values;
  bool bit = upper(type_name) == "BIT";
  if (!bit) {
    auto type = parse_type(type_name);
    if (!type) cursor_.fail("unsupported data type " + quote_text(type_name) + " for " + std::string(what));
    location.type = *type;
  }
  if (binary_) {
    cursor_.skip_to_next_line();
    location.offset = cursor_.offset();
    location.line = cursor_.line();
    uint64_t bytes = bit ? (values + 7) / 8 : 0;
    if (!bit) {
      check_fits(cursor_, values, scalar_size(location.type), what);
      bytes = values * scalar_size(location.type);
    }
    cursor_.skip(bytes, what);
  } else {
    check_fits(cursor_, values, 2, what);  // at least a digit and a separator each
    cursor_.skip_whitespace();
    location.offset = cursor_.offset();
    location.line = cursor_.line();
    for (uint64_t i = 0; i < values; ++i) {
      if (cursor_.token().empty()) cursor_.fail("file ends inside " + std::string(what));
    }
  }
  return location;
}

std::unique_ptr<ValueStream> VtkLegacyReader::stream_at(const ArrayLocation& location) const {
  if (binary_) {
    uint64_t bytes = location.values * scalar_size(location.type);
    return std::make_unique<BinaryValues>(std::make_unique<RawBytes>(file_, location.offset, bytes),
                                          location.type, /*little_endian=*/false);
  }
  return std::make_unique<AsciiValues>(file_, location.offset, location.line);
}

void VtkLegacyReader::read_field(std::optional<uint64_t> tuples,
                                 const std::function<void(std::string, uint32_t, const ArrayLocation&)>& keep) {
  cursor_.expect_token("field name");
  uint32_t arrays = cursor_.parse_int<uint32_t>("field array count");
  for (uint32_t a = 0; a < arrays; ++a) {
    std::string name(cursor_.expect_token("field array name"));
    if (upper(name) == "NULL_ARRAY") continue;
    uint32_t components = cursor_.parse_int<uint32_t>("field array component count");
    uint64_t count = cursor_.parse_int<uint64_t>("field array tuple count");
    std::string type(cursor_.expect_token("field array data type"));
    if (components == 0 || components > 1024) cursor_.fail("FIELD array '" + name + "' has " + std::to_string(components) + " components, expected 1 to 1024");
    if (count > (uint64_t{1} << 40)) cursor_.fail("FIELD array '" + name + "' is too large");
    if (tuples && count != *tuples) cursor_.fail("FIELD array '" + name + "' has " + std::to_string(count) + " tuples, expected " + std::to_string(*tuples));
    std::string t = upper(type);
    if (t == "STRING" || t == "UTF8_STRING" || t == "VARIANT") cursor_.fail("FIELD array '" + name + "' of type " + type + " is not supported");
    ArrayLocation loc = skip_array(count * components, type, "FIELD array '" + name + "'");
    if (keep && t != "BIT" && components <= 64) keep(std::move(name), components, loc);
    // VTK 9 follows an array of a FIELD with its own METADATA block
    cursor_.skip_whitespace();
    const uint64_t offset = cursor_.offset(), line = cursor_.line();
    if (upper(cursor_.token()) == "METADATA") skip_metadata();
    else cursor_.seek(offset, line);
  }
}

void VtkLegacyReader::skip_metadata() {
  std::string_view text;
  cursor_.line_text(text);
  while (cursor_.line_text(text)) {
    if (text.find_first_not_of(" \t\r") == std::string_view::npos) break;
  }
}

void VtkLegacyReader::read_attribute_section(bool point_data, uint64_t tuples, ReadStats& stats) {
  if (tuples > (uint64_t{1} << 40)) cursor_.fail(std::string(point_data ? "POINT_DATA" : "CELL_DATA") + " count too large");
  if (point_data && tuples != header_.vertex_count) {
    cursor_.fail("POINT_DATA has " + std::to_string(tuples) + " values but POINTS has " +
                 std::to_string(header_.vertex_count));
  }
  if (!point_data && tuples != cell_count_) {
    cursor_.fail("CELL_DATA has " + std::to_string(tuples) + " values but CELLS has " + std::to_string(cell_count_));
  }
  std::vector<PointArray>& arrays = point_data ? point_arrays_ : cell_arrays_;
  auto add = [&](std::string name, uint32_t components, const ArrayLocation& location, AttributeKind kind = AttributeKind::kValue) {
    for (const PointArray& a : arrays) {
      if (a.info.name == name) {
        stats.warnings.push_back(std::string("duplicate ") + (point_data ? "point" : "cell") + " array '" + name + "' ignored");
        return;
      }
    }
    arrays.push_back({{std::move(name), components, kind}, location});
  };
  for (;;) {
    cursor_.skip_whitespace();
    uint64_t keyword_offset = cursor_.offset(), keyword_line = cursor_.line();
    std::string_view token = cursor_.token();
    if (token.empty()) return;
    std::string keyword = upper(token);
    if (keyword == "SCALARS") {
      // "SCALARS name type [components]" on one line, then (in practice always) a LOOKUP_TABLE
      // line; binary data may follow either, so read lines, never a token past them
      std::string_view header_text;
      if (!cursor_.line_text(header_text)) cursor_.fail("file ends in a SCALARS header");
      std::vector<std::string> words;
      for (size_t at = 0; at < header_text.size();) {
        size_t start = header_text.find_first_not_of(" \t\r", at);
        if (start == std::string_view::npos) break;
        size_t end = header_text.find_first_of(" \t\r", start);
        words.emplace_back(header_text.substr(start, end == std::string_view::npos ? std::string_view::npos : end - start));
        at = end == std::string_view::npos ? header_text.size() : end;
      }
      if (words.size() < 2 || words.size() > 3) cursor_.fail("expected 'SCALARS name type [components]'");
      const std::string name = words[0], type = words[1];
      uint32_t components = 1;
      if (words.size() == 3) {
        uint64_t parsed = 0;
        if (!parse_number(words[2], parsed)) cursor_.fail("expected a component count, got " + quote_text(words[2]));
        components = static_cast<uint32_t>(std::min<uint64_t>(parsed, 1000));
      }
      if (components < 1 || components > 4) cursor_.fail("SCALARS '" + name + "' has " + std::to_string(components) + " components, expected 1 to 4");
      if (cursor_.next_line_starts_with("LOOKUP_TABLE") || cursor_.next_line_starts_with("lookup_table")) {
        cursor_.skip_to_next_line();
        std::string_view table;
        cursor_.line_text(table);
        // skip_array starts at the next line: step back over the newline just read
        cursor_.seek(cursor_.offset() - 1, cursor_.line() - 1);
      } else {
        cursor_.seek(cursor_.offset() - 1, cursor_.line() - 1);
      }
      ArrayLocation loc = skip_array(tuples * components, type, "SCALARS '" + name + "'");
      if (upper(type) != "BIT") add(name, components, loc);
    } else if (keyword == "VECTORS" || keyword == "NORMALS") {
      std::string name(cursor_.expect_token("vector name"));
      std::string type(cursor_.expect_token("vector data type"));
      ArrayLocation loc = skip_array(tuples * 3, type, keyword + " '" + name + "'");
      if (upper(type) != "BIT") add(name, 3, loc);
    } else if (keyword == "TENSORS" || keyword == "TENSORS6") {
      std::string name(cursor_.expect_token("tensor name"));
      std::string type(cursor_.expect_token("tensor data type"));
      // TENSORS: row-major 3x3; TENSORS6: xx yy zz xy yz xz. Both become symmetric tensors.
      uint32_t components = keyword == "TENSORS" ? 9 : 6;
      ArrayLocation loc = skip_array(tuples * components, type, keyword + " '" + name + "'");
      if (upper(type) != "BIT") add(name, components, loc, AttributeKind::kTensor);
    } else if (keyword == "TEXTURE_COORDINATES") {
      std::string name(cursor_.expect_token("texture coordinate name"));
      uint32_t dim = cursor_.parse_int<uint32_t>("texture coordinate dimension");
      if (dim < 1 || dim > 3) cursor_.fail("texture coordinate dimension must be 1 to 3");
      std::string type(cursor_.expect_token("texture coordinate data type"));
      skip_array(tuples * dim, type, "TEXTURE_COORDINATES '" + name + "'");
    } else if (keyword == "GLOBAL_IDS" || keyword == "PEDIGREE_IDS") {
      std::string name(cursor_.expect_token("id array name"));
      std::string type(cursor_.expect_token("id data type"));
      skip_array(tuples, type, keyword + " '" + name + "'");
    } else if (keyword == "COLOR_SCALARS") {
      std::string name(cursor_.expect_token("color scalars name"));
      uint32_t n = cursor_.parse_int<uint32_t>("color component count");
      if (n < 1 || n > 4) cursor_.fail("COLOR_SCALARS must have 1 to 4 components");
      skip_array(tuples * n, binary_ ? "unsigned_char" : "float", "COLOR_SCALARS '" + name + "'");
    } else if (keyword == "LOOKUP_TABLE") {
      cursor_.expect_token("lookup table name");
      uint64_t size = cursor_.parse_int<uint64_t>("lookup table size");
      if (size > (uint64_t{1} << 40)) cursor_.fail("lookup table size too large");
      skip_array(size * 4, binary_ ? "unsigned_char" : "float", "LOOKUP_TABLE");
    } else if (keyword == "FIELD") {
      read_field(tuples, [&](std::string name, uint32_t components, const ArrayLocation& loc) { add(std::move(name), components, loc); });
    } else if (keyword == "METADATA") {
      skip_metadata();
    } else {
      cursor_.seek(keyword_offset, keyword_line);  // POINT_DATA / CELL_DATA / unknown
      return;
    }
  }
}

MeshHeader VtkLegacyReader::index(ReadStats& stats) {
  header_.format = MeshFormat::kVtkLegacy;
  std::string_view text;
  if (!cursor_.line_text(text) || text.rfind("# vtk DataFile Version", 0) != 0) {
    throw MeshError(file_->name() + ": line 1: not a VTK legacy file (expected '# vtk DataFile Version')");
  }
  std::string version(text.substr(std::min<size_t>(text.size(), 23)));
  if (!cursor_.line_text(text)) cursor_.fail("file ends in the title line");
  std::string mode = upper(cursor_.expect_token("ASCII or BINARY"));
  if (mode != "ASCII" && mode != "BINARY") cursor_.fail("expected ASCII or BINARY, got " + quote_text(mode));
  binary_ = mode == "BINARY";
  header_.description = "VTK legacy " + version + " " + mode;
  if (upper(cursor_.expect_token("DATASET")) != "DATASET") cursor_.fail("expected DATASET");
  std::string dataset = upper(cursor_.expect_token("dataset type"));
  if (dataset != "UNSTRUCTURED_GRID") {
    cursor_.fail("DATASET " + dataset + " is not a volume mesh; tetrascope reads UNSTRUCTURED_GRID");
  }
  for (;;) {
    std::string_view token = cursor_.token();
    if (token.empty()) break;
    std::string keyword = upper(token);
    if (keyword == "POINTS") {
      uint64_t n = cursor_.parse_int<uint64_t>("point count");
      std::string type(cursor_.expect_token("point data type"));
      if (n > (uint64_t{1} << 40)) cursor_.fail("POINTS: " + std::to_string(n) + " declared, more than any file can hold");
      header_.vertex_count = n;
      points_ = skip_array(n * 3, type, "POINTS");
      if (n >= std::numeric_limits<uint32_t>::max()) cursor_.fail("more than 2^32-1 points are not supported");
    } else if (keyword == "CELLS") {
      uint64_t a = cursor_.parse_int<uint64_t>("cell count");
      uint64_t b = cursor_.parse_int<uint64_t>("cell list size");
      // binary cell data may follow at once: look at the next line's first bytes, never a token
      if (cursor_.next_line_starts_with("OFFSETS")) {
        cursor_.expect_token("OFFSETS");
        if (a == 0) cursor_.fail("CELLS offsets count must be at least 1");
        std::string otype(cursor_.expect_token("offset data type"));
        offsets_ = skip_array(a, otype, "OFFSETS");
        if (upper(cursor_.expect_token("CONNECTIVITY")) != "CONNECTIVITY") cursor_.fail("expected CONNECTIVITY after OFFSETS");
        std::string ctype(cursor_.expect_token("connectivity data type"));
        connectivity_ = skip_array(b, ctype, "CONNECTIVITY");
        cell_count_ = a - 1;
      } else {
        cells_ = skip_array(b, "int", "CELLS");
        cell_count_ = a;
        if (a > b) cursor_.fail("CELLS declares " + std::to_string(a) + " cells in a list of " + std::to_string(b) + " integers");
      }
    } else if (keyword == "CELL_TYPES") {
      uint64_t n = cursor_.parse_int<uint64_t>("cell type count");
      if (n != cell_count_) cursor_.fail("CELL_TYPES has " + std::to_string(n) + " entries but CELLS has " + std::to_string(cell_count_));
      cell_types_ = skip_array(n, "int", "CELL_TYPES");
    } else if (keyword == "POINT_DATA" || keyword == "CELL_DATA") {
      uint64_t n = cursor_.parse_int<uint64_t>(keyword + " count");
      read_attribute_section(keyword == "POINT_DATA", n, stats);
    } else if (keyword == "FIELD") {
      // dataset-level field data (e.g. TIME): not per vertex, skipped
      read_field(std::nullopt, nullptr);
    } else if (keyword == "METADATA") {
      skip_metadata();
    } else {
      cursor_.fail("unexpected keyword " + quote_text(token) + " in an UNSTRUCTURED_GRID");
    }
  }
  if (!points_) throw MeshError(file_->name() + ": no POINTS section");
  if (!cells_ && !connectivity_) throw MeshError(file_->name() + ": no CELLS section");
  if (!cell_types_) throw MeshError(file_->name() + ": no CELL_TYPES section");
  header_.cell_count = cell_count_;
  for (const PointArray& a : point_arrays_) header_.attributes.push_back(a.info);
  for (const PointArray& a : cell_arrays_) header_.cell_attributes.push_back(a.info);
  std::vector<std::string> names;
  std::vector<uint32_t> components;
  for (const PointArray& a : cell_arrays_) {
    names.push_back(a.info.name);
    components.push_back(a.info.kind == AttributeKind::kTensor ? 0 : a.info.components);
  }
  region_array_ = find_region_array(names, components);
  return header_;
}

void VtkLegacyReader::read_vertices(size_t count, float* xyz, std::span<float* const> attributes, ReadStats& stats) {
  if (!point_values_) {
    point_values_ = stream_at(*points_);
    for (const PointArray& a : point_arrays_) attribute_values_.push_back(stream_at(a.location));
  }
  point_values_->read_float(xyz, count * 3, /*finite_only=*/true, "point coordinate");
  for (size_t a = 0; a < point_arrays_.size(); ++a) {
    stats.nonfinite_attribute_values += read_array(*attribute_values_[a], attributes[a], count, point_arrays_[a].info);
  }
}

bool VtkLegacyReader::read_cells(CellBatch& batch, size_t max_cells) {
  if (!cells_started_) {
    cells_started_ = true;
    point_values_.reset();  // the vertex pass is over: free its buffers
    attribute_values_.clear();
    type_stream_ = stream_at(*cell_types_);
    type_ints_ = BufferedInts(type_stream_.get(), cell_types_->values);
    if (cells_) {
      cell_stream_ = stream_at(*cells_);
      cell_ints_ = BufferedInts(cell_stream_.get(), cells_->values);
    } else {
      offset_stream_ = stream_at(*offsets_);
      offset_ints_ = BufferedInts(offset_stream_.get(), offsets_->values);
      cell_stream_ = stream_at(*connectivity_);
      cell_ints_ = BufferedInts(cell_stream_.get(), connectivity_->values);
      previous_offset_ = offset_ints_.next("OFFSETS");
      if (previous_offset_ != 0) offset_stream_->fail("OFFSETS must start at 0");
    }
  }
  const uint64_t vertex_count = header_.vertex_count;
  size_t added = 0;
  while (added < max_cells && cells_read_ < cell_count_) {
    // Runs of plain tets take the bulk path; anything else (or any error) goes cell by cell.
    size_t run = static_cast<size_t>(std::min<uint64_t>({kTetRun, max_cells - added, cell_count_ - cells_read_}));
    if (slow_cells_ == 0 && run >= 16) {
      bool done = false;
      if (cells_ && cell_ints_.remaining() >= 5 * run) {
        if (append_tet_run(type_ints_.peek(run, "CELL_TYPES"), cell_ints_.peek(5 * run, "CELLS"), 5, vertex_count, batch)) {
          cell_ints_.consume(5 * run);
          done = true;
        }
      } else if (!cells_ && cell_ints_.remaining() >= 4 * run) {
        auto ends = offset_ints_.peek(run, "OFFSETS");
        bool steady = true;
        for (size_t i = 0; i < run; ++i) steady &= ends[i] == previous_offset_ + 4 * static_cast<int64_t>(i + 1);
        int64_t last = ends[run - 1];
        if (steady && append_tet_run(type_ints_.peek(run, "CELL_TYPES"), cell_ints_.peek(4 * run, "CONNECTIVITY"), 4, vertex_count, batch)) {
          offset_ints_.consume(run);
          cell_ints_.consume(4 * run);
          previous_offset_ = last;
          done = true;
        }
      }
      if (done) {
        type_ints_.consume(run);
        cells_read_ += run;
        added += run;
        continue;
      }
      slow_cells_ = run;
    }
    if (slow_cells_ > 0) --slow_cells_;
    int64_t n;
    if (cells_) {
      n = cell_ints_.next("CELLS");
      if (n < 0 || static_cast<uint64_t>(n) > cell_ints_.remaining()) {
        cell_stream_->fail("cell " + std::to_string(cells_read_) + " has an invalid vertex count " + std::to_string(n));
      }
    } else {
      int64_t next = offset_ints_.next("OFFSETS");
      n = next - previous_offset_;
      if (n < 0 || static_cast<uint64_t>(n) > cell_ints_.remaining()) {
        offset_stream_->fail("OFFSETS entry " + std::to_string(cells_read_ + 1) + " (" + std::to_string(next) + ") is out of order or past the connectivity");
      }
      previous_offset_ = next;
    }
    int64_t type = type_ints_.next("CELL_TYPES");
    append_cell(batch, cell_ints_, n, type, cells_read_, vertex_count, *type_stream_, cell_nodes_);
    if (region_array_) surfaces_.note(batch, cells_read_);
    ++cells_read_;
    ++added;
  }
  if (cells_read_ == cell_count_ && cells_ && cell_ints_.remaining() != 0 && added == 0) {
    cell_stream_->fail("CELLS list has " + std::to_string(cell_ints_.remaining()) + " integers more than its cells use");
  }
  return added > 0;
}

void VtkLegacyReader::read_cell_values(size_t count, std::span<float* const> values, ReadStats& stats) {
  if (cell_values_.empty())
    for (const PointArray& a : cell_arrays_) cell_values_.push_back(stream_at(a.location));
  for (size_t a = 0; a < cell_arrays_.size(); ++a) {
    stats.nonfinite_attribute_values += read_array(*cell_values_[a], values[a], count, cell_arrays_[a].info);
  }
}

void VtkLegacyReader::rewind_cells() {
  cells_started_ = false;
  cells_read_ = 0;
  slow_cells_ = 0;
  previous_offset_ = 0;
  cell_stream_.reset();
  offset_stream_.reset();
  type_stream_.reset();
  cell_ints_ = {};
  offset_ints_ = {};
  type_ints_ = {};
  cell_values_.clear();
  surfaces_.clear();
}

FaceTags VtkLegacyReader::take_face_tags() {
  if (!region_array_ || surfaces_.empty()) return {};
  const ArrayLocation& location = cell_arrays_[*region_array_].location;
  const bool integral = location.type != ScalarType::kFloat32 && location.type != ScalarType::kFloat64;
  const std::unique_ptr<ValueStream> values = stream_at(location);
  FaceTags tags = surfaces_.resolve(*values, integral, cell_arrays_[*region_array_].info.name);
  surfaces_.clear();
  return tags;
}

}  // namespace

std::unique_ptr<FormatReader> make_vtk_legacy_reader(std::shared_ptr<InputFile> file) {
  return std::make_unique<VtkLegacyReader>(std::move(file));
}

}  // namespace tetrascope::storage::detail
