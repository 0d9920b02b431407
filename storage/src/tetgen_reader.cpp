// TetGen .node / .ele pairs (TetGen manual, "File formats"): 0- or 1-based numbering,
// per-node attributes, optional boundary markers, 4- or 10-node tetrahedra, '#' comments.
// Attribute names come from a "# attributes: NAME ..." comment when present.
#include <cmath>
#include <sstream>

#include "format_reader.h"

namespace tetrascope::storage::detail {
namespace {

// Tokens with '#' comments (to the end of the line) skipped.
std::string_view next_token(Cursor& cursor, std::vector<std::string>* comments = nullptr) {
  for (;;) {
    std::string_view t = cursor.token();
    if (t.empty() || t.front() != '#') return t;
    std::string_view rest;
    cursor.line_text(rest);
    if (comments) comments->push_back(std::string(t.substr(1)) + " " + std::string(rest));
  }
}

int64_t next_int(Cursor& cursor, std::string_view what) {
  std::string_view t = next_token(cursor);
  int64_t v = 0;
  if (t.empty()) cursor.fail("unexpected end of file, expected " + std::string(what));
  if (!parse_number(t, v)) cursor.fail("expected " + std::string(what) + ", got " + quote_text(t));
  return v;
}

double next_double(Cursor& cursor, std::string_view what) {
  std::string_view t = next_token(cursor);
  double v = 0;
  if (t.empty()) cursor.fail("unexpected end of file, expected " + std::string(what));
  if (!parse_number(t, v)) cursor.fail("expected " + std::string(what) + ", got " + quote_text(t));
  return v;
}

class TetgenReader final : public FormatReader {
 public:
  TetgenReader(std::shared_ptr<InputFile> node, std::shared_ptr<InputFile> ele)
      : node_file_(std::move(node)), ele_file_(std::move(ele)), node_(node_file_), ele_(ele_file_) {}

  MeshHeader index(ReadStats&) override {
    header_.format = MeshFormat::kTetgen;
    header_.description = "TetGen .node/.ele";
    std::vector<std::string> comments;
    std::string_view first = next_token(node_, &comments);
    int64_t points = 0;
    if (first.empty() || !parse_number(first, points) || points < 0) node_.fail("expected the number of points in the .node header");
    int64_t dim = next_int(node_, "dimension");
    attributes_ = next_int(node_, "number of attributes");
    markers_ = next_int(node_, "number of boundary markers");
    if (dim != 3) node_.fail("dimension must be 3, got " + std::to_string(dim));
    if (attributes_ < 0 || attributes_ > 256) node_.fail("number of attributes must be 0 to 256");
    if (markers_ < 0 || markers_ > 1) node_.fail("number of boundary markers must be 0 or 1");
    check_fits(node_, static_cast<uint64_t>(points), 8, "points");
    if (static_cast<uint64_t>(points) >= std::numeric_limits<uint32_t>::max()) node_.fail("more than 2^32-1 points are not supported");
    header_.vertex_count = static_cast<uint64_t>(points);
    // Comments before the first point may name the attributes.
    uint64_t mark = node_.offset(), mark_line = node_.line();
    std::string_view peek = next_token(node_, &comments);
    node_.seek(mark, mark_line);
    (void)peek;
    std::vector<std::string> names;
    for (const std::string& c : comments) {
      size_t at = c.find("attributes:");
      if (at == std::string::npos) continue;
      std::istringstream words(c.substr(at + 11));
      for (std::string w; words >> w;) names.push_back(w);
    }
    for (int64_t a = 0; a < attributes_; ++a) {
      std::string name = static_cast<size_t>(a) < names.size() && static_cast<int64_t>(names.size()) == attributes_
                             ? names[static_cast<size_t>(a)] : "attribute" + std::to_string(a);
      header_.attributes.push_back({name, 1});
    }
    int64_t tets = next_int(ele_, "number of tetrahedra in the .ele header");
    nodes_per_tet_ = next_int(ele_, "nodes per tetrahedron");
    ele_attributes_ = next_int(ele_, "number of region attributes");
    if (tets < 0) ele_.fail("negative number of tetrahedra");
    if (nodes_per_tet_ != 4 && nodes_per_tet_ != 10) ele_.fail("nodes per tetrahedron must be 4 or 10, got " + std::to_string(nodes_per_tet_));
    if (ele_attributes_ < 0 || ele_attributes_ > 256) ele_.fail("number of region attributes must be 0 to 256");
    check_fits(ele_, static_cast<uint64_t>(tets), 10, "tetrahedra");
    header_.cell_count = static_cast<uint64_t>(tets);
    return header_;
  }

  void read_vertices(size_t count, float* xyz, std::span<float* const> attributes, ReadStats& stats) override {
    for (size_t i = 0; i < count; ++i, ++vertices_read_) {
      int64_t index = next_int(node_, "point index");
      if (vertices_read_ == 0) {
        if (index != 0 && index != 1) node_.fail("the first point must be numbered 0 or 1, got " + std::to_string(index));
        base_ = index;
      } else if (index != base_ + static_cast<int64_t>(vertices_read_)) {
        node_.fail("points must be numbered consecutively: expected " + std::to_string(base_ + static_cast<int64_t>(vertices_read_)) + ", got " + std::to_string(index));
      }
      for (int k = 0; k < 3; ++k) {
        double v = next_double(node_, "coordinate");
        if (!to_stored_float(v, xyz[3 * i + static_cast<size_t>(k)])) {
          node_.fail(not_a_float_message("point " + std::to_string(index) + ": coordinate", v));
        }
      }
      for (int64_t a = 0; a < attributes_; ++a) {
        double v = next_double(node_, "attribute");
        if (!to_stored_float(v, attributes[static_cast<size_t>(a)][i])) ++stats.nonfinite_attribute_values;
      }
      if (markers_ == 1) next_int(node_, "boundary marker");
    }
  }

  bool read_cells(CellBatch& batch, size_t max_cells) override {
    size_t added = 0;
    uint32_t nodes[4];
    while (added < max_cells && cells_read_ < header_.cell_count) {
      next_int(ele_, "tetrahedron index");
      for (int64_t k = 0; k < nodes_per_tet_; ++k) {
        int64_t v = next_int(ele_, "node index") - base_;
        if (v < 0 || static_cast<uint64_t>(v) >= header_.vertex_count) {
          ele_.fail("tetrahedron " + std::to_string(cells_read_) + ": node " + std::to_string(v + base_) + " out of range (the .node file has " +
                    std::to_string(header_.vertex_count) + " points numbered from " + std::to_string(base_) + ")");
        }
        if (k < 4) nodes[k] = static_cast<uint32_t>(v);
      }
      for (int64_t a = 0; a < ele_attributes_; ++a) next_double(ele_, "region attribute");
      if (nodes_per_tet_ == 10) ++batch.reduced;
      batch.push(kVtkTetra, nodes);
      ++cells_read_;
      ++added;
    }
    return added > 0;
  }

 private:
  std::shared_ptr<InputFile> node_file_, ele_file_;
  Cursor node_, ele_;
  MeshHeader header_;
  int64_t attributes_ = 0, markers_ = 0, nodes_per_tet_ = 4, ele_attributes_ = 0;
  int64_t base_ = 0;
  uint64_t vertices_read_ = 0, cells_read_ = 0;
};

}  // namespace

std::unique_ptr<FormatReader> make_tetgen_reader(std::shared_ptr<InputFile> node, std::shared_ptr<InputFile> ele) {
  return std::make_unique<TetgenReader>(std::move(node), std::move(ele));
}

}  // namespace tetrascope::storage::detail
