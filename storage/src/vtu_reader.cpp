// VTK XML unstructured grids (.vtu): inline ascii and base64 binary, appended raw and
// base64, optional vtkZLibDataCompressor framing, UInt32 or UInt64 block headers, either
// byte order; triangles and quads beside the volume cells tagged by a region-id CellData
// array become boundary face tags (region_tags.h). Format: "VTK File Formats", XML section,
// and vtkXMLDataParser.
#include <cstdio>
#include <map>
#include <optional>

#include "format_reader.h"
#include "region_tags.h"

namespace tetrascope::storage::detail {
namespace {

constexpr size_t kMaxTagBytes = 64 * 1024;
// zlib cannot expand data by more than about 1032:1; used to bound declared sizes.
constexpr uint64_t kMaxCompressionRatio = 1100;

struct Tag {
  std::string name;
  std::map<std::string, std::string> attributes;
  bool closing = false;
  bool self_closing = false;
  uint64_t line = 0;
  const std::string* find(const std::string& key) const {
    auto it = attributes.find(key);
    return it == attributes.end() ? nullptr : &it->second;
  }
};

struct DataArray {
  std::string name;
  ScalarType type = ScalarType::kFloat32;
  uint32_t components = 1;
  bool tensor = false;  // 9 components (row-major 3x3) or 6 (xx yy zz xy yz xz)
  enum class Format { kAscii, kBinary, kAppended } format = Format::kAscii;
  uint64_t content_offset = 0, content_line = 0;  // inline content
  uint64_t appended_offset = 0;
  uint64_t ascii_tokens = 0;
  uint64_t line = 0;
};

// `count` tuples of an array. A NaN or infinite value is counted, except in a tensor: there it
// fails, naming the array and where its values are, since no eigen-analysis can use it.
uint64_t read_array(ValueStream& values, float* out, size_t count, const DataArray& a) {
  if (a.tensor) return values.read_float(out, count * a.components, true, "tensor '" + a.name + "' value");
  return values.read_float(out, count * a.components, false, a.name);
}

std::string decode_entities(std::string_view v) {
  std::string out;
  for (size_t i = 0; i < v.size(); ++i) {
    if (v[i] != '&') {
      out += v[i];
      continue;
    }
    static const std::pair<std::string_view, char> kEntities[] = {
        {"&amp;", '&'}, {"&lt;", '<'}, {"&gt;", '>'}, {"&quot;", '"'}, {"&apos;", '\''}};
    bool done = false;
    for (auto [entity, ch] : kEntities) {
      if (v.substr(i, entity.size()) == entity) {
        out += ch;
        i += entity.size() - 1;
        done = true;
        break;
      }
    }
    if (!done) out += '&';
  }
  return out;
}

std::optional<ScalarType> vtu_type(std::string_view t) {
  if (t == "Int8" || t == "Char") return ScalarType::kInt8;
  if (t == "UInt8") return ScalarType::kUInt8;
  if (t == "Int16") return ScalarType::kInt16;
  if (t == "UInt16") return ScalarType::kUInt16;
  if (t == "Int32") return ScalarType::kInt32;
  if (t == "UInt32") return ScalarType::kUInt32;
  if (t == "Int64") return ScalarType::kInt64;
  if (t == "UInt64") return ScalarType::kUInt64;
  if (t == "Float32") return ScalarType::kFloat32;
  if (t == "Float64") return ScalarType::kFloat64;
  return std::nullopt;
}

class VtuReader final : public FormatReader {
 public:
  explicit VtuReader(std::shared_ptr<InputFile> file) : file_(std::move(file)), cursor_(file_) {}
  MeshHeader index(ReadStats& stats) override;
  void read_vertices(size_t count, float* xyz, std::span<float* const> attributes, ReadStats& stats) override;
  bool read_cells(CellBatch& batch, size_t max_cells) override;
  void read_cell_values(size_t count, std::span<float* const> values, ReadStats& stats) override;
  void rewind_cells() override;
  FaceTags take_face_tags() override;

 private:
  bool next_tag(Tag& tag);
  [[noreturn]] void fail_line(uint64_t line, const std::string& what) const {
    throw MeshError(file_->name() + ": line " + std::to_string(line) + ": " + what);
  }
  // `tensors_name`: the array the enclosing PointData/CellData names as its Tensors, if any.
  DataArray parse_array(const Tag& tag, const std::string& tensors_name);
  // Opens the values of `array`, which must hold exactly `values` numbers.
  std::unique_ptr<ValueStream> open_values(const DataArray& array, uint64_t values) const;
  // Number of values an integer array holds, from its encoding header or token count.
  uint64_t value_count(const DataArray& array) const;
  uint64_t appended_start(const DataArray& array) const;
  // Fails when the compressed arrays would inflate past ReadLimits (a decompression bomb).
  void check_inflated_size() const;

  std::shared_ptr<InputFile> file_;
  Cursor cursor_;
  bool little_endian_ = true;
  bool header_uint64_ = false;
  bool compressed_ = false;
  bool appended_base64_ = false;
  std::optional<uint64_t> appended_offset_;
  MeshHeader header_;
  std::optional<DataArray> points_, connectivity_, offsets_, types_;
  std::vector<DataArray> point_arrays_, cell_arrays_;

  std::unique_ptr<ValueStream> point_values_;
  std::vector<std::unique_ptr<ValueStream>> attribute_values_;
  bool cells_started_ = false;
  uint64_t cells_read_ = 0;
  int64_t previous_end_ = 0;
  static constexpr uint64_t kTetRun = 1024;
  size_t slow_cells_ = 0;  // cells left to read one by one after a run that was not plain tets
  std::unique_ptr<ValueStream> connectivity_stream_, offset_stream_, type_stream_;
  BufferedInts connectivity_ints_, offset_ints_, type_ints_;
  std::vector<uint32_t> cell_nodes_;
  std::vector<std::unique_ptr<ValueStream>> cell_values_;
  std::optional<size_t> region_array_;  // the cell array of region ids, if any
  SurfaceRegions surfaces_;
};

bool VtuReader::next_tag(Tag& tag) {
  for (;;) {
    if (!cursor_.skip_until('<')) return false;
    tag = Tag();
    tag.line = cursor_.line();
    cursor_.get();  // '<'
    std::string text;
    char quote = 0;
    for (;;) {
      int c = cursor_.get();
      if (c < 0) cursor_.fail("file ends inside an XML tag");
      if (quote) {
        if (c == quote) quote = 0;
      } else if (c == '"' || c == '\'') {
        quote = static_cast<char>(c);
      } else if (c == '>') {
        break;
      }
      text += static_cast<char>(c);
      if (text.size() > kMaxTagBytes) cursor_.fail("XML tag longer than " + std::to_string(kMaxTagBytes) + " bytes");
      if (text.size() == 3 && text == "!--") {  // comment: skip to "-->"
        int dashes = 0;
        for (;;) {
          int d = cursor_.get();
          if (d < 0) cursor_.fail("file ends inside an XML comment");
          if (d == '>' && dashes >= 2) break;
          dashes = d == '-' ? dashes + 1 : 0;
        }
        text.clear();
        break;
      }
    }
    if (text.empty() || text[0] == '?' || text[0] == '!') continue;
    size_t i = 0;
    if (text[0] == '/') {
      tag.closing = true;
      i = 1;
    }
    if (text.size() > i && text.back() == '/') {
      tag.self_closing = true;
      text.pop_back();
    }
    if (text.size() <= i) fail_line(tag.line, "empty XML tag");
    size_t name_end = text.find_first_of(" \t\r\n", i);
    tag.name = text.substr(i, name_end == std::string::npos ? std::string::npos : name_end - i);
    size_t p = name_end;
    while (p != std::string::npos && p < text.size()) {
      p = text.find_first_not_of(" \t\r\n", p);
      if (p == std::string::npos) break;
      size_t eq = text.find('=', p);
      if (eq == std::string::npos) fail_line(tag.line, "malformed attribute in <" + tag.name + ">");
      std::string key = text.substr(p, eq - p);
      while (!key.empty() && (key.back() == ' ' || key.back() == '\t')) key.pop_back();
      size_t q = text.find_first_of("\"'", eq);
      if (q == std::string::npos) fail_line(tag.line, "unquoted attribute '" + key + "' in <" + tag.name + ">");
      size_t q_end = text.find(text[q], q + 1);
      if (q_end == std::string::npos) fail_line(tag.line, "unterminated attribute '" + key + "' in <" + tag.name + ">");
      tag.attributes[key] = decode_entities(std::string_view(text).substr(q + 1, q_end - q - 1));
      p = q_end + 1;
    }
    return true;
  }
}

DataArray VtuReader::parse_array(const Tag& tag, const std::string& tensors_name) {
  DataArray a;
  a.line = tag.line;
  if (const std::string* name = tag.find("Name")) a.name = *name;
  const std::string* type = tag.find("type");
  if (!type) fail_line(tag.line, "DataArray '" + a.name + "' has no type");
  auto t = vtu_type(*type);
  if (!t) fail_line(tag.line, "DataArray '" + a.name + "' has unsupported type " + quote_text(*type));
  a.type = *t;
  if (const std::string* nc = tag.find("NumberOfComponents")) {
    uint64_t n = 0;
    if (!parse_number(*nc, n) || n == 0 || n > 64) fail_line(tag.line, "DataArray '" + a.name + "': NumberOfComponents must be 1 to 64, got " + quote_text(*nc));
    a.components = static_cast<uint32_t>(n);
  }
  // ParaView's convention: 9 components are a tensor, 6 a symmetric one in VTK's order
  if (!tensors_name.empty() && a.name == tensors_name && a.components != 9 && a.components != 6)
    fail_line(tag.line, "DataArray '" + a.name + "' is the Tensors array but has " + std::to_string(a.components) + " components, expected 9 (3x3) or 6 (xx yy zz xy yz xz)");
  a.tensor = a.components == 9 || a.components == 6;
  std::string format = tag.find("format") ? *tag.find("format") : "ascii";
  if (format == "ascii") {
    a.format = DataArray::Format::kAscii;
  } else if (format == "binary") {
    a.format = DataArray::Format::kBinary;
  } else if (format == "appended") {
    a.format = DataArray::Format::kAppended;
    const std::string* offset = tag.find("offset");
    if (!offset || !parse_number(*offset, a.appended_offset)) fail_line(tag.line, "appended DataArray '" + a.name + "' needs a numeric offset");
  } else {
    fail_line(tag.line, "DataArray '" + a.name + "' has unknown format " + quote_text(format));
  }
  if (a.format != DataArray::Format::kAppended && !tag.self_closing) {
    a.content_offset = cursor_.offset();
    a.content_line = cursor_.line();
    uint64_t* count = a.format == DataArray::Format::kAscii ? &a.ascii_tokens : nullptr;
    if (!cursor_.skip_until('<', count)) cursor_.fail("file ends inside DataArray '" + a.name + "'");
  }
  return a;
}

MeshHeader VtuReader::index(ReadStats& stats) {
  header_.format = MeshFormat::kVtu;
  Tag tag;
  enum class Section { kNone, kPoints, kCells, kPointData, kCellData, kOther } section = Section::kNone;
  bool have_piece = false, have_root = false;
  std::string tensors_name;  // the enclosing PointData/CellData's Tensors="..."
  while (next_tag(tag)) {
    if (tag.name == "VTKFile" && !tag.closing) {
      have_root = true;
      const std::string* type = tag.find("type");
      if (!type || *type != "UnstructuredGrid") {
        fail_line(tag.line, "VTKFile type " + (type ? quote_text(*type) : std::string("(none)")) + " is not a volume mesh; tetrascope reads UnstructuredGrid");
      }
      if (const std::string* order = tag.find("byte_order")) {
        if (*order == "BigEndian") little_endian_ = false;
        else if (*order != "LittleEndian") fail_line(tag.line, "unknown byte_order " + quote_text(*order));
      }
      if (const std::string* ht = tag.find("header_type")) {
        if (*ht == "UInt64") header_uint64_ = true;
        else if (*ht != "UInt32") fail_line(tag.line, "unsupported header_type " + quote_text(*ht) + " (expected UInt32 or UInt64)");
      }
      if (const std::string* comp = tag.find("compressor")) {
        if (*comp == "vtkZLibDataCompressor") compressed_ = true;
        else if (!comp->empty()) fail_line(tag.line, "compressor " + quote_text(*comp) + " is not supported (write with vtkZLibDataCompressor or none)");
      }
      std::string version = tag.find("version") ? *tag.find("version") : "?";
      header_.description = "VTK XML UnstructuredGrid " + version + (compressed_ ? " zlib" : "");
      continue;
    }
    if (!have_root && !tag.closing) fail_line(tag.line, "not a VTK XML file (expected <VTKFile>)");
    if (tag.name == "Piece" && !tag.closing) {
      if (have_piece) fail_line(tag.line, "more than one Piece; tetrascope reads single-piece .vtu files (merge pieces first)");
      have_piece = true;
      const std::string* np = tag.find("NumberOfPoints");
      const std::string* nc = tag.find("NumberOfCells");
      uint64_t points = 0, cells = 0;
      if (!np || !parse_number(*np, points)) fail_line(tag.line, "Piece needs a numeric NumberOfPoints");
      std::string nc_text = nc ? *nc : "";
      nc_text.erase(0, nc_text.find_first_not_of(' '));
      if (!nc || !parse_number(nc_text, cells)) fail_line(tag.line, "Piece needs a numeric NumberOfCells");
      uint64_t bound = file_->size() * (compressed_ ? kMaxCompressionRatio : 1);
      if (points >= std::numeric_limits<uint32_t>::max() || points > bound / 2) {
        fail_line(tag.line, "NumberOfPoints " + std::to_string(points) + " does not fit in a file of " + std::to_string(file_->size()) + " bytes");
      }
      if (cells > bound) fail_line(tag.line, "NumberOfCells " + std::to_string(cells) + " does not fit in a file of " + std::to_string(file_->size()) + " bytes");
      header_.vertex_count = points;
      header_.cell_count = cells;
    } else if (tag.name == "Points") {
      section = tag.closing ? Section::kNone : Section::kPoints;
    } else if (tag.name == "Cells") {
      section = tag.closing ? Section::kNone : Section::kCells;
    } else if (tag.name == "PointData" || tag.name == "CellData") {
      const Section data = tag.name == "PointData" ? Section::kPointData : Section::kCellData;
      section = tag.closing || tag.self_closing ? Section::kNone : data;
      tensors_name = !tag.closing && tag.find("Tensors") ? *tag.find("Tensors") : std::string();
    } else if (tag.name == "FieldData") {
      section = tag.closing || tag.self_closing ? Section::kNone : Section::kOther;
    } else if (tag.name == "DataArray" && !tag.closing) {
      if (!have_piece) fail_line(tag.line, "DataArray outside a Piece");
      DataArray a = parse_array(tag, section == Section::kPointData || section == Section::kCellData ? tensors_name : std::string());
      switch (section) {
        case Section::kPoints:
          if (a.components != 3) fail_line(tag.line, "Points must have 3 components, got " + std::to_string(a.components));
          points_ = a;
          break;
        case Section::kCells:
          if (a.name == "connectivity") connectivity_ = a;
          else if (a.name == "offsets") offsets_ = a;
          else if (a.name == "types") types_ = a;
          break;
        case Section::kPointData:
        case Section::kCellData: {
          const bool point = section == Section::kPointData;
          std::vector<DataArray>& arrays = point ? point_arrays_ : cell_arrays_;
          bool duplicate = false;
          for (const DataArray& b : arrays) duplicate |= b.name == a.name;
          if (duplicate) {
            stats.warnings.push_back(std::string("duplicate ") + (point ? "point" : "cell") + " array '" + a.name + "' ignored");
          } else {
            if (a.name.empty()) a.name = (point ? "array" : "cell_array") + std::to_string(arrays.size());
            arrays.push_back(a);
          }
          break;
        }
        default: break;
      }
    } else if (tag.name == "AppendedData" && !tag.closing) {
      std::string encoding = tag.find("encoding") ? *tag.find("encoding") : "raw";
      if (encoding == "base64") appended_base64_ = true;
      else if (encoding != "raw") fail_line(tag.line, "unknown AppendedData encoding " + quote_text(encoding));
      cursor_.skip_whitespace();
      if (cursor_.get() != '_') cursor_.fail("expected '_' at the start of AppendedData");
      appended_offset_ = cursor_.offset();
      break;  // binary data follows; everything needed was seen
    }
  }
  if (!have_root) throw MeshError(file_->name() + ": not a VTK XML file (no <VTKFile>)");
  if (!have_piece) throw MeshError(file_->name() + ": no <Piece> in the UnstructuredGrid");
  if (!points_) throw MeshError(file_->name() + ": no Points DataArray");
  if (!connectivity_ || !offsets_ || !types_) throw MeshError(file_->name() + ": Cells must hold connectivity, offsets and types arrays");
  for (const DataArray* a : {&*points_, &*connectivity_, &*offsets_, &*types_}) {
    if (a->format == DataArray::Format::kAppended && !appended_offset_) fail_line(a->line, "DataArray '" + a->name + "' is appended but the file has no AppendedData");
  }
  for (const DataArray& a : point_arrays_) header_.attributes.push_back({a.name, a.components, a.tensor ? AttributeKind::kTensor : AttributeKind::kValue});
  for (const DataArray& a : cell_arrays_) {
    if (a.format == DataArray::Format::kAppended && !appended_offset_) fail_line(a.line, "DataArray '" + a.name + "' is appended but the file has no AppendedData");
    header_.cell_attributes.push_back({a.name, a.components, a.tensor ? AttributeKind::kTensor : AttributeKind::kValue});
  }
  if (compressed_) check_inflated_size();
  std::vector<std::string> names;
  std::vector<uint32_t> components;
  for (const DataArray& a : cell_arrays_) {
    names.push_back(a.name);
    components.push_back(a.tensor ? 0 : a.components);
  }
  region_array_ = find_region_array(names, components);
  return header_;
}

void VtuReader::check_inflated_size() const {
  // What the arrays that will be read inflate to, from the declared counts (the zlib headers
  // are checked against the same counts when each array is opened).
  const uint64_t points = header_.vertex_count, cells = header_.cell_count;
  double inflated = 0;
  auto add = [&](const DataArray& a, double values) {
    if (a.format != DataArray::Format::kAscii) inflated += values * static_cast<double>(scalar_size(a.type));
  };
  add(*points_, 3.0 * static_cast<double>(points));
  for (const DataArray& a : point_arrays_) add(a, static_cast<double>(points) * a.components);
  for (const DataArray& a : cell_arrays_) add(a, static_cast<double>(cells) * a.components);
  add(*offsets_, static_cast<double>(cells));
  add(*types_, static_cast<double>(cells));
  if (connectivity_->format != DataArray::Format::kAscii) add(*connectivity_, static_cast<double>(value_count(*connectivity_)));
  const uint64_t limit = file_->limits().max_inflated_bytes(file_->size());
  if (inflated > static_cast<double>(limit)) {
    char ratio[32];
    std::snprintf(ratio, sizeof ratio, "%g", file_->limits().max_inflate_ratio);
    throw MeshError(file_->name() + ": its compressed arrays inflate to " + std::to_string(static_cast<uint64_t>(inflated)) + " bytes, more than " +
                    std::to_string(limit) + " allowed for a file of " + std::to_string(file_->size()) + " bytes (" + ratio + " times its size plus " +
                    std::to_string(ReadLimits::kInflateAllowanceBytes >> 20) + " MiB; raise --max-inflate-ratio if the file is genuine)");
  }
}

uint64_t VtuReader::appended_start(const DataArray& a) const {
  uint64_t start = *appended_offset_ + a.appended_offset;
  if (a.appended_offset > file_->size() || start > file_->size()) fail_line(a.line, "DataArray '" + a.name + "' offset points past the end of the file");
  return start;
}

std::unique_ptr<ValueStream> VtuReader::open_values(const DataArray& a, uint64_t values) const {
  if (a.format == DataArray::Format::kAscii) {
    if (a.ascii_tokens < values) fail_line(a.line, "DataArray '" + a.name + "' holds " + std::to_string(a.ascii_tokens) + " values, expected " + std::to_string(values));
    return std::make_unique<AsciiValues>(file_, a.content_offset, a.content_line, '<');  // "1.5</DataArray>"
  }
  const uint64_t size = scalar_size(a.type);
  if (values > file_->size() * kMaxCompressionRatio / size) fail_line(a.line, "DataArray '" + a.name + "' is larger than the file can hold");
  const uint64_t bytes = values * size;
  std::unique_ptr<ByteStream> stream;
  bool base64 = a.format == DataArray::Format::kBinary || appended_base64_;
  if (base64) {
    uint64_t offset = a.format == DataArray::Format::kBinary ? a.content_offset : appended_start(a);
    stream = std::make_unique<Base64Bytes>(file_, offset, a.content_line);
  } else {
    uint64_t offset = appended_start(a);
    stream = std::make_unique<RawBytes>(file_, offset, file_->size() - offset);
  }
  if (compressed_) {
    stream = std::make_unique<ZlibBlocks>(std::move(stream), header_uint64_, little_endian_, bytes, file_->size(), "compressed DataArray '" + a.name + "'");
  } else {
    uint8_t head[8] = {};
    size_t item = header_uint64_ ? 8 : 4;
    stream->read(head, item, "DataArray '" + a.name + "' size header");
    int64_t declared = 0;
    decode_values(head, 1, header_uint64_ ? ScalarType::kUInt64 : ScalarType::kUInt32, little_endian_, &declared);
    if (declared < 0 || static_cast<uint64_t>(declared) != bytes) {
      fail_line(a.line, "DataArray '" + a.name + "' holds " + std::to_string(declared) + " bytes, expected " + std::to_string(bytes));
    }
  }
  return std::make_unique<BinaryValues>(std::move(stream), a.type, little_endian_);
}

uint64_t VtuReader::value_count(const DataArray& a) const {
  if (a.format == DataArray::Format::kAscii) return a.ascii_tokens;
  const size_t item = header_uint64_ ? 8 : 4;
  std::unique_ptr<ByteStream> stream;
  if (a.format == DataArray::Format::kBinary || appended_base64_) {
    uint64_t offset = a.format == DataArray::Format::kBinary ? a.content_offset : appended_start(a);
    stream = std::make_unique<Base64Bytes>(file_, offset, a.content_line);
  } else {
    uint64_t offset = appended_start(a);
    stream = std::make_unique<RawBytes>(file_, offset, file_->size() - offset);
  }
  uint8_t head[24] = {};
  const ScalarType header_type = header_uint64_ ? ScalarType::kUInt64 : ScalarType::kUInt32;
  uint64_t bytes = 0;
  if (compressed_) {
    stream->read(head, 3 * item, "compression header");
    int64_t v[3];
    decode_values(head, 3, header_type, little_endian_, v);
    if (v[0] < 0 || v[1] < 0 || v[2] < 0) fail_line(a.line, "DataArray '" + a.name + "' has a corrupt compression header");
    uint64_t blocks = static_cast<uint64_t>(v[0]), block = static_cast<uint64_t>(v[1]), last = static_cast<uint64_t>(v[2]);
    if (blocks > file_->size() || block > (uint64_t{1} << 31)) fail_line(a.line, "DataArray '" + a.name + "' has a corrupt compression header");
    bytes = blocks == 0 ? 0 : (blocks - 1) * block + (last == 0 ? block : last);
  } else {
    stream->read(head, item, "DataArray size header");
    int64_t v = 0;
    decode_values(head, 1, header_type, little_endian_, &v);
    if (v < 0) fail_line(a.line, "DataArray '" + a.name + "' has a corrupt size header");
    bytes = static_cast<uint64_t>(v);
  }
  if (bytes % scalar_size(a.type) != 0) fail_line(a.line, "DataArray '" + a.name + "' size is not a multiple of its type");
  return bytes / scalar_size(a.type);
}

void VtuReader::read_vertices(size_t count, float* xyz, std::span<float* const> attributes, ReadStats& stats) {
  if (!point_values_) {
    point_values_ = open_values(*points_, header_.vertex_count * 3);
    for (const DataArray& a : point_arrays_) attribute_values_.push_back(open_values(a, header_.vertex_count * a.components));
  }
  point_values_->read_float(xyz, count * 3, true, "point coordinate");
  for (size_t a = 0; a < point_arrays_.size(); ++a) {
    stats.nonfinite_attribute_values += read_array(*attribute_values_[a], attributes[a], count, point_arrays_[a]);
  }
}

bool VtuReader::read_cells(CellBatch& batch, size_t max_cells) {
  const uint64_t cell_count = header_.cell_count;
  if (!cells_started_) {
    cells_started_ = true;
    point_values_.reset();  // the vertex pass is over: free its buffers
    attribute_values_.clear();
    uint64_t connectivity_values = value_count(*connectivity_);
    connectivity_stream_ = open_values(*connectivity_, connectivity_values);
    offset_stream_ = open_values(*offsets_, cell_count);
    type_stream_ = open_values(*types_, cell_count);
    connectivity_ints_ = BufferedInts(connectivity_stream_.get(), connectivity_values);
    offset_ints_ = BufferedInts(offset_stream_.get(), cell_count);
    type_ints_ = BufferedInts(type_stream_.get(), cell_count);
  }
  const uint64_t vertex_count = header_.vertex_count;
  size_t added = 0;
  while (added < max_cells && cells_read_ < cell_count) {
    // Runs of plain tets take the bulk path; anything else (or any error) goes cell by cell.
    size_t run = static_cast<size_t>(std::min<uint64_t>({kTetRun, max_cells - added, cell_count - cells_read_}));
    if (slow_cells_ == 0 && run >= 16 && connectivity_ints_.remaining() >= 4 * run) {
      auto ends = offset_ints_.peek(run, "offsets");
      bool steady = true;
      for (size_t i = 0; i < run; ++i) steady &= ends[i] == previous_end_ + 4 * static_cast<int64_t>(i + 1);
      int64_t last_end = ends[run - 1];
      if (steady && append_tet_run(type_ints_.peek(run, "types"), connectivity_ints_.peek(4 * run, "connectivity"), 4, vertex_count, batch)) {
        offset_ints_.consume(run);
        type_ints_.consume(run);
        connectivity_ints_.consume(4 * run);
        previous_end_ = last_end;
        cells_read_ += run;
        added += run;
        continue;
      }
      slow_cells_ = run;
    }
    if (slow_cells_ > 0) --slow_cells_;
    int64_t end = offset_ints_.next("offsets");
    int64_t n = end - previous_end_;
    if (n < 0 || static_cast<uint64_t>(n) > connectivity_ints_.remaining()) {
      offset_stream_->fail("cell " + std::to_string(cells_read_) + ": offset " + std::to_string(end) + " is out of order or past the connectivity");
    }
    previous_end_ = end;
    int64_t type = type_ints_.next("types");
    append_cell(batch, connectivity_ints_, n, type, cells_read_, vertex_count, *type_stream_, cell_nodes_);
    if (region_array_) surfaces_.note(batch, cells_read_);
    ++cells_read_;
    ++added;
  }
  return added > 0;
}

void VtuReader::read_cell_values(size_t count, std::span<float* const> values, ReadStats& stats) {
  if (cell_values_.empty())
    for (const DataArray& a : cell_arrays_) cell_values_.push_back(open_values(a, header_.cell_count * a.components));
  for (size_t a = 0; a < cell_arrays_.size(); ++a) {
    stats.nonfinite_attribute_values += read_array(*cell_values_[a], values[a], count, cell_arrays_[a]);
  }
}

void VtuReader::rewind_cells() {
  cells_started_ = false;
  cells_read_ = 0;
  previous_end_ = 0;
  slow_cells_ = 0;
  connectivity_stream_.reset();
  offset_stream_.reset();
  type_stream_.reset();
  connectivity_ints_ = {};
  offset_ints_ = {};
  type_ints_ = {};
  cell_values_.clear();
  surfaces_.clear();
}

FaceTags VtuReader::take_face_tags() {
  if (!region_array_ || surfaces_.empty()) return {};
  const DataArray& a = cell_arrays_[*region_array_];
  const bool integral = a.type != ScalarType::kFloat32 && a.type != ScalarType::kFloat64;
  const std::unique_ptr<ValueStream> values = open_values(a, header_.cell_count);
  FaceTags tags = surfaces_.resolve(*values, integral, a.name);
  surfaces_.clear();
  return tags;
}

}  // namespace

std::unique_ptr<FormatReader> make_vtu_reader(std::shared_ptr<InputFile> file) {
  return std::make_unique<VtuReader>(std::move(file));
}

}  // namespace tetrascope::storage::detail
