// OFF-tetra, the ASCII form the classic unstructured volume-rendering sets (Blunt Fin, SPX,
// F117) were passed around in (e.g. by HAVS): "numVerts numTets", then "x y z [scalar...]"
// per vertex, then "i j k l" per tet, 0-based. An optional "OFF" first line and an optional
// leading "4" on tet lines are accepted.
#include <cmath>

#include "format_reader.h"

namespace tetrascope::storage::detail {
namespace {

int count_columns(std::string_view text) {
  int columns = 0;
  for (size_t p = 0; p < text.size();) {
    size_t s = text.find_first_not_of(" \t\r", p);
    if (s == std::string_view::npos) break;
    ++columns;
    size_t e = text.find_first_of(" \t\r", s);
    p = e == std::string_view::npos ? text.size() : e;
  }
  return columns;
}

class OffReader final : public FormatReader {
 public:
  explicit OffReader(std::shared_ptr<InputFile> file) : file_(std::move(file)), cursor_(file_) {}

  MeshHeader index(ReadStats&) override {
    header_.format = MeshFormat::kOff;
    header_.description = "OFF tetrahedra (ASCII)";
    uint64_t mark = cursor_.offset(), mark_line = cursor_.line();
    std::string_view first = cursor_.token();
    if (first != "OFF" && first != "TOFF" && first != "OFF-TET") cursor_.seek(mark, mark_line);
    std::string_view text;
    cursor_.skip_whitespace();
    if (!cursor_.line_text(text)) throw MeshError(file_->name() + ": empty file");
    uint64_t counts[3] = {0, 0, 0};
    int fields = 0;
    for (size_t p = 0; p < text.size() && fields < 4;) {
      size_t s = text.find_first_not_of(" \t\r", p);
      if (s == std::string_view::npos) break;
      size_t e = text.find_first_of(" \t\r", s);
      std::string_view word = text.substr(s, e == std::string_view::npos ? std::string_view::npos : e - s);
      if (fields < 3 && !parse_number(word, counts[fields])) {
        throw MeshError(file_->name() + ": line " + std::to_string(cursor_.line() - 1) + ": expected 'numVerts numTets', got " + quote_text(word));
      }
      ++fields;
      p = e == std::string_view::npos ? text.size() : e;
    }
    if (fields < 2) throw MeshError(file_->name() + ": line " + std::to_string(cursor_.line() - 1) + ": expected 'numVerts numTets'");
    header_.vertex_count = counts[0];
    header_.cell_count = counts[1];
    check_fits(cursor_, counts[0], 6, "vertices");
    check_fits(cursor_, counts[1], 8, "tetrahedra");
    if (counts[0] >= std::numeric_limits<uint32_t>::max()) cursor_.fail("more than 2^32-1 vertices are not supported");
    // The first vertex line tells how many values follow the coordinates.
    data_offset_ = cursor_.offset();
    data_line_ = cursor_.line();
    if (counts[0] > 0) {
      cursor_.skip_whitespace();
      uint64_t line = cursor_.line();
      if (!cursor_.line_text(text)) cursor_.fail("file ends before the first vertex");
      int columns = count_columns(text);
      if (columns < 3 || columns > 3 + 64) {
        throw MeshError(file_->name() + ": line " + std::to_string(line) + ": a vertex needs x y z and at most 64 values, got " + std::to_string(columns) + " columns");
      }
      scalars_ = columns - 3;
      for (int s = 0; s < scalars_; ++s) header_.attributes.push_back({scalars_ == 1 ? "scalar" : "scalar" + std::to_string(s), 1});
      cursor_.seek(data_offset_, data_line_);
    }
    return header_;
  }

  void read_vertices(size_t count, float* xyz, std::span<float* const> attributes, ReadStats& stats) override {
    for (size_t i = 0; i < count; ++i) {
      for (int k = 0; k < 3; ++k) {
        double v = cursor_.parse_double("vertex coordinate");
        if (!to_stored_float(v, xyz[3 * i + static_cast<size_t>(k)])) {
          cursor_.fail(not_a_float_message("vertex " + std::to_string(vertices_read_ + i) + ": coordinate", v));
        }
      }
      for (int s = 0; s < scalars_; ++s) {
        double v = cursor_.parse_double("vertex scalar");
        if (!to_stored_float(v, attributes[static_cast<size_t>(s)][i])) ++stats.nonfinite_attribute_values;
      }
    }
    vertices_read_ += count;
  }

  bool read_cells(CellBatch& batch, size_t max_cells) override {
    size_t added = 0;
    uint32_t nodes[4];
    int64_t values[5];
    while (added < max_cells && cells_read_ < header_.cell_count) {
      if (cells_read_ == 0) {
        // "4 i j k l" or "i j k l": look at the first line
        uint64_t mark = cursor_.offset(), line = cursor_.line();
        cursor_.skip_whitespace();
        std::string_view text;
        cursor_.line_text(text);
        int columns = count_columns(text);
        counted_ = columns == 5;
        cursor_.seek(mark, line);
      }
      int n = counted_ ? 5 : 4;
      for (int k = 0; k < n; ++k) values[k] = cursor_.parse_int<int64_t>("tetrahedron vertex index");
      if (counted_ && values[0] != 4) cursor_.fail("tetrahedron " + std::to_string(cells_read_) + " has " + std::to_string(values[0]) + " vertices, expected 4");
      for (int k = 0; k < 4; ++k) {
        int64_t v = values[k + (counted_ ? 1 : 0)];
        if (v < 0 || static_cast<uint64_t>(v) >= header_.vertex_count) {
          cursor_.fail("tetrahedron " + std::to_string(cells_read_) + ": vertex index " + std::to_string(v) + " out of range (the mesh has " +
                       std::to_string(header_.vertex_count) + " vertices, numbered from 0)");
        }
        nodes[k] = static_cast<uint32_t>(v);
      }
      batch.push(kVtkTetra, nodes);
      ++cells_read_;
      ++added;
    }
    return added > 0;
  }

 private:
  std::shared_ptr<InputFile> file_;
  Cursor cursor_;
  MeshHeader header_;
  uint64_t data_offset_ = 0, data_line_ = 1;
  int scalars_ = 0;
  bool counted_ = false;
  uint64_t vertices_read_ = 0, cells_read_ = 0;
};

}  // namespace

std::unique_ptr<FormatReader> make_off_reader(std::shared_ptr<InputFile> file) {
  return std::make_unique<OffReader>(std::move(file));
}

}  // namespace tetrascope::storage::detail
