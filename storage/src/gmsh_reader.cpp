// Gmsh MSH 2.2 and 4.1 meshes, ASCII and binary, with $NodeData and $ElementData fields.
// Format: Gmsh reference manual, "MSH file format" (versions 4.1 and 2.2).
// A data section's first integer tag numbers its time step and its first real tag is the
// step's time: the steps are the distinct numbers in the order they first appear. A field is
// read at the last section of its name, or, with ReadLimits::time_step, at that step, every
// step of a field then giving values for the same nodes (elements).
// Nodes and fields are read while indexing (memory in proportion to the vertices: tags
// may be sparse and fields come last); elements are streamed.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <unordered_map>

#include "format_reader.h"

namespace tetrascope::storage::detail {
namespace {

struct GmshType {
  int vtk_type;   // linear VTK type, or a lower-dimensional one that is skipped
  int nodes;      // nodes stored per element
  int corners;    // corner nodes (first in Gmsh's order)
};

// Element types of the Gmsh manual; 0 nodes = unknown.
GmshType gmsh_type(int type) {
  switch (type) {
    case 1: return {kVtkLine, 2, 2};
    case 2: return {kVtkTriangle, 3, 3};
    case 3: return {kVtkQuad, 4, 4};
    case 4: return {kVtkTetra, 4, 4};
    case 5: return {kVtkHexahedron, 8, 8};
    case 6: return {kVtkWedge, 6, 6};
    case 7: return {kVtkPyramid, 5, 5};
    case 8: return {kVtkLine, 3, 2};
    case 9: return {kVtkTriangle, 6, 3};
    case 10: return {kVtkQuad, 9, 4};
    case 11: return {kVtkTetra, 10, 4};
    case 12: return {kVtkHexahedron, 27, 8};
    case 13: return {kVtkWedge, 18, 6};
    case 14: return {kVtkPyramid, 14, 5};
    case 15: return {kVtkVertex, 1, 1};
    case 16: return {kVtkQuad, 8, 4};
    case 17: return {kVtkHexahedron, 20, 8};
    case 18: return {kVtkWedge, 15, 6};
    case 19: return {kVtkPyramid, 13, 5};
    case 20: return {kVtkTriangle, 9, 3};
    case 21: return {kVtkTriangle, 10, 3};
    case 22: return {kVtkTriangle, 12, 3};
    case 23: return {kVtkTriangle, 15, 3};
    case 24: return {kVtkTriangle, 15, 3};
    case 25: return {kVtkTriangle, 21, 3};
    case 26: return {kVtkLine, 4, 2};
    case 27: return {kVtkLine, 5, 2};
    case 28: return {kVtkLine, 6, 2};
    case 29: return {kVtkTetra, 20, 4};
    case 30: return {kVtkTetra, 35, 4};
    case 31: return {kVtkTetra, 56, 4};
    case 92: return {kVtkHexahedron, 64, 8};
    case 93: return {kVtkHexahedron, 125, 8};
    default: return {0, 0, 0};
  }
}

constexpr size_t kMaxSteps = 100000;  // as a time series holds at most (storage::kMaxTimeSteps)

struct Field {
  AttributeInfo info;
  std::vector<float> values;
  size_t step = 0;  // the time step it is of (GmshReader::steps_)
};

// $ElementData: values by element tag, sorted by tag.
struct ElementField {
  AttributeInfo info;
  std::vector<int64_t> tags;
  std::vector<float> values;  // components per tag, in the order of `tags`
  size_t step = 0;
};

// The header of a $NodeData or $ElementData section.
struct DataHeader {
  std::string name;
  int64_t components = 1, count = 0;
  int64_t step = 0;  // the time step's number (the first integer tag)
  double time = 0;   // its time (the first real tag), else the step's number
};

class GmshReader final : public FormatReader {
 public:
  GmshReader(std::shared_ptr<InputFile> file, int64_t time_step) : file_(std::move(file)), cursor_(file_), time_step_(time_step) {}
  MeshHeader index(ReadStats& stats) override;
  void read_vertices(size_t count, float* xyz, std::span<float* const> attributes, ReadStats& stats) override;
  bool read_cells(CellBatch& batch, size_t max_cells) override;
  void read_cell_values(size_t count, std::span<float* const> values, ReadStats& stats) override;
  void rewind_cells() override;
  FaceTags take_face_tags() override { return std::move(face_tags_); }

 private:
  template <typename T>
  T binary(std::string_view what) {
    uint8_t raw[8];
    cursor_.read(raw, sizeof(T), what);
    if constexpr (std::is_floating_point_v<T>) {
      double v;
      decode_values(raw, 1, ScalarType::kFloat64, little_endian_, &v);
      return static_cast<T>(v);
    } else {
      int64_t v;
      decode_values(raw, 1, sizeof(T) == 4 ? ScalarType::kInt32 : ScalarType::kUInt64, little_endian_, &v);
      return static_cast<T>(v);
    }
  }
  uint64_t count_value(std::string_view what);  // a size_t in 4.1 binary, else ASCII
  void expect_end(const std::string& section);
  void skip_section(const std::string& section);
  void read_nodes();
  void add_node(uint64_t tag, double x, double y, double z);
  uint32_t node_index(int64_t tag, const char* what, uint64_t number);
  DataHeader read_data_header(const std::string& section, uint64_t most);
  // The size of an entity tag in a binary data section (MSH 4.1 writers differ: int or size_t):
  // the one whose payload ends at $End<section>.
  size_t binary_tag_bytes(const std::string& section, int64_t count, int64_t components);
  // Fails at the value just read: its line in an ASCII file, its byte in a binary one.
  [[noreturn]] void fail_here(const std::string& what) const {
    if (binary_) cursor_.fail_byte(what);
    cursor_.fail(what);
  }
  void read_node_data(ReadStats& stats);
  void read_element_data(ReadStats& stats);
  // The place of a data section's time step among the file's (a new number joins the end).
  size_t step_of(const DataHeader& h);
  std::string step_text(size_t step) const;
  // With a time step chosen: a field's entities (nodes or elements, as `covered` lists them)
  // are those of its first section; fails naming both steps otherwise.
  void check_same_entities(const std::string& section, const std::string& name, size_t step, std::vector<uint64_t> covered);
  void skip_elements();
  bool next_element(CellBatch& batch);
  void read_physical_names();
  void read_entities();
  // A triangle or quad of physical surface `physical` (0: none) joins the tagged faces.
  void tag_face(int vtk_type, int64_t physical);

  std::shared_ptr<InputFile> file_;
  Cursor cursor_;
  bool version4_ = false;
  bool binary_ = false;
  bool little_endian_ = true;
  MeshHeader header_;
  std::vector<float> xyz_;
  std::vector<uint32_t> dense_tags_;                  // tag -> index when tags are dense
  std::unordered_map<uint64_t, uint32_t> sparse_tags_;
  std::vector<uint64_t> node_tags_;
  std::vector<Field> fields_;
  std::vector<ElementField> element_fields_;
  std::vector<int64_t> batch_tags_;  // the tags of the elements the last read_cells appended
  uint64_t elements_offset_ = 0, elements_line_ = 0;
  bool have_elements_ = false;
  uint64_t vertices_given_ = 0;

  // element streaming state
  bool elements_started_ = false;
  uint64_t elements_left_ = 0, block_left_ = 0, blocks_left_ = 0;
  uint64_t elements_read_ = 0;
  int block_type_ = 0, block_tags_ = 0;
  std::vector<uint32_t> cell_nodes_;
  int32_t block_dim_ = 0, block_entity_ = 0;  // MSH 4.1: the entity of the current block
  // boundary faces by physical surface: $PhysicalNames of dimension 2, and in MSH 4.1 each
  // surface entity's first physical tag ($Entities)
  std::unordered_map<int64_t, std::string> surface_names_;
  std::unordered_map<int32_t, int64_t> surface_physical_;
  std::unordered_map<int64_t, uint32_t> tag_of_physical_;
  FaceTags face_tags_;
  std::vector<int64_t> element_ints_;
  std::vector<uint8_t> element_bytes_;
  // time steps: each number's time, in order of appearance; the step read (-1: each field's last)
  std::vector<std::pair<int64_t, double>> steps_;
  int64_t time_step_ = -1;
  // with a step chosen: each field's first step and the entities it covers ("NodeData name")
  std::unordered_map<std::string, std::pair<size_t, std::vector<uint64_t>>> covered_;
};

uint64_t GmshReader::count_value(std::string_view what) {
  if (binary_ && version4_) return binary<uint64_t>(what);
  return cursor_.parse_int<uint64_t>(what);
}

void GmshReader::expect_end(const std::string& section) {
  std::string_view t = cursor_.expect_token("$End" + section);
  if (t != "$End" + section) cursor_.fail("expected $End" + section + ", got " + quote_text(t));
}

void GmshReader::skip_section(const std::string& section) {
  // Unknown sections are skipped up to their end marker at the start of a line.
  const std::string end = "$End" + section;
  for (;;) {
    if (!cursor_.skip_until('$')) cursor_.fail("file ends inside $" + section);
    uint64_t offset = cursor_.offset(), line = cursor_.line();
    std::string_view t = cursor_.token();
    if (t == end) return;
    cursor_.seek(offset + 1, line);
  }
}

void GmshReader::add_node(uint64_t tag, double x, double y, double z) {
  const double c[3] = {x, y, z};
  float f[3];
  for (int k = 0; k < 3; ++k) {
    if (to_stored_float(c[k], f[k])) continue;
    std::string what = not_a_float_message("node " + std::to_string(tag) + ": coordinate", c[k]);
    if (binary_) cursor_.fail_byte(what);  // the node's data ends here
    cursor_.fail(what);
  }
  node_tags_.push_back(tag);
  xyz_.insert(xyz_.end(), f, f + 3);
}

void GmshReader::read_nodes() {
  if (!xyz_.empty()) cursor_.fail("second $Nodes section");
  if (!version4_) {
    uint64_t n = cursor_.parse_int<uint64_t>("node count");
    check_fits(cursor_, n, binary_ ? 28 : 8, "$Nodes");
    if (binary_) cursor_.skip_to_next_line();
    xyz_.reserve(3 * n);
    node_tags_.reserve(n);
    for (uint64_t i = 0; i < n; ++i) {
      if (binary_) {
        int64_t tag = binary<int32_t>("node tag");
        double x = binary<double>("node x"), y = binary<double>("node y"), z = binary<double>("node z");
        if (tag <= 0) cursor_.fail_byte("invalid node tag " + std::to_string(tag));
        add_node(static_cast<uint64_t>(tag), x, y, z);
      } else {
        uint64_t tag = cursor_.parse_int<uint64_t>("node tag");
        double x = cursor_.parse_double("x"), y = cursor_.parse_double("y"), z = cursor_.parse_double("z");
        add_node(tag, x, y, z);
      }
    }
  } else {
    if (binary_) cursor_.skip_to_next_line();
    uint64_t blocks = count_value("node block count");
    uint64_t n = count_value("node count");
    count_value("minimum node tag");
    count_value("maximum node tag");
    check_fits(cursor_, n, binary_ ? 32 : 8, "$Nodes");
    check_fits(cursor_, blocks, binary_ ? 20 : 8, "$Nodes entity blocks");
    xyz_.reserve(3 * n);
    node_tags_.reserve(n);
    std::vector<uint64_t> tags;
    for (uint64_t b = 0; b < blocks; ++b) {
      int dim, parametric;
      uint64_t in_block;
      if (binary_) {
        dim = binary<int32_t>("entity dimension");
        binary<int32_t>("entity tag");
        parametric = binary<int32_t>("parametric flag");
        in_block = binary<uint64_t>("nodes in block");
      } else {
        dim = cursor_.parse_int<int32_t>("entity dimension");
        cursor_.parse_int<int32_t>("entity tag");
        parametric = cursor_.parse_int<int32_t>("parametric flag");
        in_block = cursor_.parse_int<uint64_t>("nodes in block");
      }
      if (dim < 0 || dim > 3 || parametric < 0 || parametric > 1) cursor_.fail("invalid node block header");
      if (in_block > n - node_tags_.size()) cursor_.fail("node blocks hold more nodes than the declared " + std::to_string(n));
      tags.resize(static_cast<size_t>(in_block));
      for (auto& tag : tags) tag = binary_ ? binary<uint64_t>("node tag") : cursor_.parse_int<uint64_t>("node tag");
      int extra = parametric ? dim : 0;
      for (uint64_t i = 0; i < in_block; ++i) {
        double c[6];
        for (int k = 0; k < 3 + extra; ++k) c[k] = binary_ ? binary<double>("node coordinate") : cursor_.parse_double("node coordinate");
        add_node(tags[i], c[0], c[1], c[2]);
      }
    }
    if (node_tags_.size() != n) cursor_.fail("$Nodes declares " + std::to_string(n) + " nodes but its blocks hold " + std::to_string(node_tags_.size()));
  }
  expect_end("Nodes");
  if (node_tags_.size() >= std::numeric_limits<uint32_t>::max()) cursor_.fail("more than 2^32-1 nodes are not supported");
  uint64_t max_tag = 0;
  for (uint64_t t : node_tags_) max_tag = std::max(max_tag, t);
  bool dense = max_tag <= 2 * node_tags_.size() + 1024;
  if (dense) dense_tags_.assign(static_cast<size_t>(max_tag) + 1, std::numeric_limits<uint32_t>::max());
  for (size_t i = 0; i < node_tags_.size(); ++i) {
    uint64_t t = node_tags_[i];
    bool clash = dense ? dense_tags_[t] != std::numeric_limits<uint32_t>::max() : sparse_tags_.count(t) != 0;
    if (clash) cursor_.fail("node tag " + std::to_string(t) + " appears twice in $Nodes");
    if (dense) dense_tags_[t] = static_cast<uint32_t>(i);
    else sparse_tags_[t] = static_cast<uint32_t>(i);
  }
  header_.vertex_count = node_tags_.size();
}

uint32_t GmshReader::node_index(int64_t tag, const char* context, uint64_t number) {
  uint32_t index = std::numeric_limits<uint32_t>::max();
  if (tag >= 0) {
    uint64_t t = static_cast<uint64_t>(tag);
    if (!dense_tags_.empty()) {
      if (t < dense_tags_.size()) index = dense_tags_[t];
    } else if (auto it = sparse_tags_.find(t); it != sparse_tags_.end()) {
      index = it->second;
    }
  }
  if (index == std::numeric_limits<uint32_t>::max()) {
    std::string what = std::string(context) + " " + std::to_string(number) + " refers to node " + std::to_string(tag) + ", which is not in $Nodes";
    if (binary_) cursor_.fail_byte(what);
    cursor_.fail(what);
  }
  return index;
}

DataHeader GmshReader::read_data_header(const std::string& section, uint64_t most) {
  DataHeader h;
  h.name = "field" + std::to_string(fields_.size() + element_fields_.size());
  uint32_t strings = cursor_.parse_int<uint32_t>("number of string tags");
  if (strings > 64) cursor_.fail("too many string tags");
  std::string_view text;
  cursor_.skip_to_next_line();
  for (uint32_t s = 0; s < strings; ++s) {
    if (!cursor_.line_text(text)) cursor_.fail("file ends in $" + section + " string tags");
    std::string tag(text);
    while (!tag.empty() && (tag.back() == ' ' || tag.back() == '\r')) tag.pop_back();
    if (tag.size() >= 2 && tag.front() == '"' && tag.back() == '"') tag = tag.substr(1, tag.size() - 2);
    if (s == 0 && !tag.empty()) h.name = tag;
  }
  uint32_t reals = cursor_.parse_int<uint32_t>("number of real tags");
  if (reals > 64) cursor_.fail("too many real tags");
  for (uint32_t r = 0; r < reals; ++r) {
    const double v = cursor_.parse_double("real tag");
    if (r == 0) h.time = v;
  }
  uint32_t ints = cursor_.parse_int<uint32_t>("number of integer tags");
  if (ints < 3 || ints > 64) cursor_.fail("$" + section + " needs 3 integer tags (time step, components, count)");
  int64_t int_tags[64];
  for (uint32_t i = 0; i < ints; ++i) int_tags[i] = cursor_.parse_int<int64_t>("integer tag");
  h.step = int_tags[0];
  if (reals == 0) h.time = static_cast<double>(h.step);
  h.components = int_tags[1];
  h.count = int_tags[2];
  if (h.components != 1 && h.components != 3 && h.components != 9) cursor_.fail("$" + section + " '" + h.name + "' has " + std::to_string(h.components) + " components, expected 1 (scalar), 3 (vector) or 9 (tensor)");
  if (h.count < 0 || static_cast<uint64_t>(h.count) > most) cursor_.fail("$" + section + " '" + h.name + "' has " + std::to_string(h.count) + " values for " + std::to_string(most) + (section == "NodeData" ? " nodes" : " elements"));
  return h;
}

size_t GmshReader::binary_tag_bytes(const std::string& section, int64_t count, int64_t components) {
  if (!binary_) return 4;
  cursor_.skip_to_next_line();
  const uint64_t start = cursor_.offset(), line = cursor_.line();
  auto ends_right = [&](size_t bytes) {
    uint64_t payload = static_cast<uint64_t>(count) * (bytes + 8 * static_cast<uint64_t>(components));
    if (payload > cursor_.remaining()) return false;
    cursor_.skip(payload, "$" + section);
    std::string_view t = cursor_.token();
    cursor_.seek(start, line);
    return t == "$End" + section;
  };
  return !ends_right(4) && ends_right(8) ? 8 : 4;
}

void GmshReader::read_node_data(ReadStats& stats) {
  if (xyz_.empty()) cursor_.fail("$NodeData before $Nodes");
  const DataHeader h = read_data_header("NodeData", node_tags_.size());
  const std::string& name = h.name;
  const int64_t components = h.components, count = h.count;
  // 9 components are a tensor (Gmsh's views: row-major 3x3), kept symmetric by MeshStream
  Field field{{name, static_cast<uint32_t>(components), components == 9 ? AttributeKind::kTensor : AttributeKind::kValue}, {}};
  field.values.assign(node_tags_.size() * static_cast<size_t>(components), std::numeric_limits<float>::quiet_NaN());
  std::vector<uint8_t> seen(node_tags_.size(), 0);
  const size_t tag_bytes = binary_tag_bytes("NodeData", count, components);
  for (int64_t i = 0; i < count; ++i) {
    int64_t tag = binary_ ? (tag_bytes == 4 ? binary<int32_t>("node tag") : static_cast<int64_t>(binary<uint64_t>("node tag")))
                          : cursor_.parse_int<int64_t>("node tag");
    uint32_t index = node_index(tag, "$NodeData entry", static_cast<uint64_t>(i));
    seen[index] = 1;
    for (int64_t k = 0; k < components; ++k) {
      double v = binary_ ? binary<double>("field value") : cursor_.parse_double("field value");
      if (!to_stored_float(v, field.values[index * static_cast<size_t>(components) + static_cast<size_t>(k)])) {
        if (components == 9) fail_here("$NodeData '" + name + "': tensor value " + std::to_string(v) + " is not a finite 32-bit float");
        ++stats.nonfinite_attribute_values;
      }
    }
  }
  expect_end("NodeData");
  const size_t step = step_of(h);
  if (time_step_ >= 0) {
    std::vector<uint64_t> unseen;  // the nodes it leaves out: few, most often none
    for (size_t i = 0; i < seen.size(); ++i)
      if (!seen[i]) unseen.push_back(i);
    check_same_entities("NodeData", name, step, std::move(unseen));
    if (step != static_cast<size_t>(time_step_)) return;  // another step's values
  }
  field.step = step;
  size_t missing = 0;
  for (uint8_t s : seen) missing += s == 0;
  if (missing > 0) {
    stats.warnings.push_back("$NodeData '" + name + "' has no value for " + std::to_string(missing) + " nodes (set to NaN)");
    stats.nonfinite_attribute_values += missing * static_cast<uint64_t>(components);
  }
  for (Field& f : fields_) {
    if (f.info.name == name) {  // a later time step replaces an earlier one
      if (f.step == step) stats.warnings.push_back("$NodeData '" + name + "' appears more than once at " + step_text(step) + "; using the last one");
      f = std::move(field);
      return;
    }
  }
  fields_.push_back(std::move(field));
}

void GmshReader::read_element_data(ReadStats& stats) {
  // the count is checked against the file's size (a value at least 2 bytes), the elements
  // against it once they are read
  const DataHeader h = read_data_header("ElementData", cursor_.remaining() / 2);
  const size_t components = static_cast<size_t>(h.components), count = static_cast<size_t>(h.count);
  const size_t tag_bytes = binary_tag_bytes("ElementData", h.count, h.components);
  std::vector<std::pair<int64_t, size_t>> order(count);
  std::vector<float> raw(count * components);
  for (size_t i = 0; i < count; ++i) {
    int64_t tag = binary_ ? (tag_bytes == 4 ? binary<int32_t>("element tag") : static_cast<int64_t>(binary<uint64_t>("element tag")))
                          : cursor_.parse_int<int64_t>("element tag");
    order[i] = {tag, i};
    for (size_t k = 0; k < components; ++k) {
      double v = binary_ ? binary<double>("field value") : cursor_.parse_double("field value");
      if (!to_stored_float(v, raw[i * components + k])) {
        if (components == 9) fail_here("$ElementData '" + h.name + "': tensor value " + std::to_string(v) + " is not a finite 32-bit float");
        ++stats.nonfinite_attribute_values;
      }
    }
  }
  expect_end("ElementData");
  std::sort(order.begin(), order.end());
  ElementField field{{h.name, static_cast<uint32_t>(components), components == 9 ? AttributeKind::kTensor : AttributeKind::kValue}, {}, {}, step_of(h)};
  field.tags.reserve(count);
  field.values.reserve(count * components);
  for (size_t i = 0; i < count; ++i) {
    if (i > 0 && order[i].first == order[i - 1].first) cursor_.fail("$ElementData '" + h.name + "' gives element " + std::to_string(order[i].first) + " twice");
    field.tags.push_back(order[i].first);
    field.values.insert(field.values.end(), raw.begin() + static_cast<std::ptrdiff_t>(order[i].second * components), raw.begin() + static_cast<std::ptrdiff_t>((order[i].second + 1) * components));
  }
  if (time_step_ >= 0) {
    check_same_entities("ElementData", h.name, field.step, std::vector<uint64_t>(field.tags.begin(), field.tags.end()));
    if (field.step != static_cast<size_t>(time_step_)) return;  // another step's values
  }
  for (ElementField& f : element_fields_) {
    if (f.info.name == h.name) {  // a later time step replaces an earlier one
      if (f.step == field.step) stats.warnings.push_back("$ElementData '" + h.name + "' appears more than once at " + step_text(field.step) + "; using the last one");
      f = std::move(field);
      return;
    }
  }
  element_fields_.push_back(std::move(field));
}

size_t GmshReader::step_of(const DataHeader& h) {
  for (size_t i = 0; i < steps_.size(); ++i)
    if (steps_[i].first == h.step) return i;
  if (steps_.size() >= kMaxSteps) cursor_.fail("more than " + std::to_string(kMaxSteps) + " time steps");
  steps_.emplace_back(h.step, h.time);
  return steps_.size() - 1;
}

std::string GmshReader::step_text(size_t step) const {
  char text[96];
  std::snprintf(text, sizeof text, "time step %zu (number %lld, t = %g)", step, static_cast<long long>(steps_[step].first), steps_[step].second);
  return text;
}

void GmshReader::check_same_entities(const std::string& section, const std::string& name, size_t step, std::vector<uint64_t> listed) {
  const auto found = covered_.find(section + " " + name);
  if (found == covered_.end()) {
    covered_.emplace(section + " " + name, std::make_pair(step, std::move(listed)));
    return;
  }
  if (found->second.second == listed) return;
  const char* what = section == "NodeData" ? "nodes" : "elements";
  cursor_.fail("$" + section + " '" + name + "' at " + step_text(step) + " gives values for other " + what + " than at " + step_text(found->second.first) +
               ": every time step of a series has values for the same " + what);
}

void GmshReader::skip_elements() {
  // Counts and skips $Elements so that later sections can be read; elements are streamed later.
  elements_offset_ = cursor_.offset();
  elements_line_ = cursor_.line();
  have_elements_ = true;
  if (!binary_) {
    if (version4_) cursor_.parse_int<uint64_t>("element block count");
    header_.cell_count = cursor_.parse_int<uint64_t>("element count");
    skip_section("Elements");
    return;
  }
  if (!version4_) {
    uint64_t n = cursor_.parse_int<uint64_t>("element count");
    header_.cell_count = n;
    cursor_.skip_to_next_line();
    uint64_t done = 0;
    while (done < n) {
      int32_t type = binary<int32_t>("element type"), count = binary<int32_t>("element count"), tags = binary<int32_t>("tag count");
      GmshType g = gmsh_type(type);
      if (g.nodes == 0) cursor_.fail_byte("unknown Gmsh element type " + std::to_string(type));
      if (count <= 0 || tags < 0 || tags > 64 || static_cast<uint64_t>(count) > n - done) cursor_.fail_byte("invalid element block header");
      cursor_.skip(static_cast<uint64_t>(count) * (1 + static_cast<uint64_t>(tags) + static_cast<uint64_t>(g.nodes)) * 4, "$Elements");
      done += static_cast<uint64_t>(count);
    }
  } else {
    cursor_.skip_to_next_line();
    uint64_t blocks = binary<uint64_t>("element block count"), n = binary<uint64_t>("element count");
    binary<uint64_t>("minimum element tag");
    binary<uint64_t>("maximum element tag");
    header_.cell_count = n;
    check_fits(cursor_, blocks, 20, "$Elements blocks");
    uint64_t done = 0;
    for (uint64_t b = 0; b < blocks; ++b) {
      binary<int32_t>("entity dimension");
      binary<int32_t>("entity tag");
      int32_t type = binary<int32_t>("element type");
      uint64_t count = binary<uint64_t>("elements in block");
      GmshType g = gmsh_type(type);
      if (g.nodes == 0) cursor_.fail_byte("unknown Gmsh element type " + std::to_string(type));
      if (count > n - done) cursor_.fail_byte("element blocks hold more elements than declared");
      check_fits(cursor_, count, 8 * (1 + static_cast<uint64_t>(g.nodes)), "$Elements block");
      cursor_.skip(count * 8 * (1 + static_cast<uint64_t>(g.nodes)), "$Elements");
      done += count;
    }
  }
  expect_end("Elements");
}

MeshHeader GmshReader::index(ReadStats& stats) {
  header_.format = MeshFormat::kGmsh;
  if (cursor_.token() != "$MeshFormat") throw MeshError(file_->name() + ": line 1: not a Gmsh file (expected $MeshFormat)");
  std::string version(cursor_.expect_token("format version"));
  int file_type = cursor_.parse_int<int32_t>("file type");
  int data_size = cursor_.parse_int<int32_t>("data size");
  if (version == "4.1") version4_ = true;
  else if (version.rfind("2.", 0) != 0) cursor_.fail("Gmsh format " + version + " is not supported (write MSH 2.2 or 4.1)");
  if (file_type != 0 && file_type != 1) cursor_.fail("file type must be 0 (ASCII) or 1 (binary)");
  if (data_size != 8) cursor_.fail("data size must be 8");
  binary_ = file_type == 1;
  if (binary_) {
    cursor_.skip_to_next_line();
    uint8_t one[4];
    cursor_.read(one, 4, "byte-order marker");
    if (one[0] == 1 && one[1] == 0 && one[2] == 0 && one[3] == 0) little_endian_ = true;
    else if (one[0] == 0 && one[1] == 0 && one[2] == 0 && one[3] == 1) little_endian_ = false;
    else cursor_.fail_byte("invalid byte-order marker");
  }
  expect_end("MeshFormat");
  header_.description = "Gmsh " + version + (binary_ ? " binary" : " ASCII");
  for (;;) {
    std::string_view t = cursor_.token();
    if (t.empty()) break;
    if (t.front() != '$') cursor_.fail("expected a section like $Nodes, got " + quote_text(t));
    std::string section(t.substr(1));
    if (section == "Nodes") read_nodes();
    else if (section == "Elements") skip_elements();
    else if (section == "NodeData") read_node_data(stats);
    else if (section == "ElementData") read_element_data(stats);
    else if (section == "PhysicalNames") read_physical_names();
    else if (section == "Entities" && version4_) read_entities();
    else {
      if (section == "ElementNodeData") stats.warnings.push_back("$" + section + " ignored (values per element corner are not read)");
      if (binary_ && section != "PhysicalNames" && section != "ElementData" && section != "ElementNodeData" &&
          section != "Entities" && section != "PartitionedEntities" && section != "Periodic" && section != "GhostElements" &&
          section != "Parametrizations" && section != "InterpolationScheme") {
        stats.warnings.push_back("section $" + section + " skipped");
      }
      skip_section(section);
    }
  }
  if (xyz_.empty() && header_.vertex_count == 0) throw MeshError(file_->name() + ": no $Nodes section");
  if (time_step_ >= 0 && static_cast<size_t>(time_step_) >= std::max<size_t>(steps_.size(), 1))
    throw MeshError(file_->name() + ": time step " + std::to_string(time_step_) + " asked for, the file holds " + std::to_string(std::max<size_t>(steps_.size(), 1)));
  if (steps_.size() > 1) {
    for (const auto& [number, time] : steps_) header_.step_times.push_back(time);
    if (time_step_ < 0) stats.warnings.push_back(std::to_string(steps_.size()) + " time steps: each field's last is read (preprocess --all-steps reads them all)");
  }
  if (!have_elements_) throw MeshError(file_->name() + ": no $Elements section");
  for (const Field& f : fields_) header_.attributes.push_back(f.info);
  for (const ElementField& f : element_fields_) header_.cell_attributes.push_back(f.info);
  return header_;
}

void GmshReader::read_vertices(size_t count, float* xyz, std::span<float* const> attributes, ReadStats&) {
  std::memcpy(xyz, xyz_.data() + 3 * vertices_given_, 3 * count * sizeof(float));
  for (size_t a = 0; a < fields_.size(); ++a) {
    size_t c = fields_[a].info.components;
    std::memcpy(attributes[a], fields_[a].values.data() + vertices_given_ * c, count * c * sizeof(float));
  }
  vertices_given_ += count;
  if (vertices_given_ == header_.vertex_count) {  // release what the stream now holds
    std::vector<float>().swap(xyz_);
    for (Field& f : fields_) std::vector<float>().swap(f.values);
  }
}

bool GmshReader::next_element(CellBatch& batch) {
  int type;
  int64_t element_tag = 0, physical = 0;
  if (!version4_) {
    if (elements_left_ == 0) return false;
    if (binary_ && block_left_ == 0) {
      block_type_ = binary<int32_t>("element type");
      int32_t count = binary<int32_t>("element count");
      block_tags_ = binary<int32_t>("tag count");
      if (count <= 0 || block_tags_ < 0 || block_tags_ > 64) cursor_.fail_byte("invalid element block header");
      block_left_ = static_cast<uint64_t>(count);
    }
    if (binary_) {
      type = block_type_;
      element_tag = binary<int32_t>("element number");
      for (int k = 0; k < block_tags_; ++k) {
        const int32_t value = binary<int32_t>("element tag");
        if (k == 0) physical = value;  // MSH 2: the first tag is the physical entity
      }
      --block_left_;
    } else {
      element_tag = cursor_.parse_int<int64_t>("element number");
      type = cursor_.parse_int<int32_t>("element type");
      int tags = cursor_.parse_int<int32_t>("number of tags");
      if (tags < 0 || tags > 64) cursor_.fail("element has " + std::to_string(tags) + " tags");
      for (int k = 0; k < tags; ++k) {
        const int64_t value = cursor_.parse_int<int64_t>("element tag");
        if (k == 0) physical = value;  // MSH 2: the first tag is the physical entity
      }
    }
    --elements_left_;
  } else {
    while (block_left_ == 0) {
      if (blocks_left_ == 0) return false;
      if (binary_) {
        block_dim_ = binary<int32_t>("entity dimension");
        block_entity_ = binary<int32_t>("entity tag");
        block_type_ = binary<int32_t>("element type");
        block_left_ = binary<uint64_t>("elements in block");
      } else {
        block_dim_ = cursor_.parse_int<int32_t>("entity dimension");
        block_entity_ = cursor_.parse_int<int32_t>("entity tag");
        block_type_ = cursor_.parse_int<int32_t>("element type");
        block_left_ = cursor_.parse_int<uint64_t>("elements in block");
      }
      --blocks_left_;
      if (block_left_ > elements_left_) cursor_.fail("element blocks hold more elements than declared");
    }
    type = block_type_;
    if (block_dim_ == 2)
      if (auto it = surface_physical_.find(block_entity_); it != surface_physical_.end()) physical = it->second;
    element_tag = binary_ ? static_cast<int64_t>(binary<uint64_t>("element tag")) : static_cast<int64_t>(cursor_.parse_int<uint64_t>("element tag"));
    --block_left_;
    --elements_left_;
  }
  GmshType g = gmsh_type(type);
  if (g.nodes == 0) {
    std::string what = "element " + std::to_string(elements_read_) + ": unknown Gmsh element type " + std::to_string(type);
    if (binary_) cursor_.fail_byte(what);
    cursor_.fail(what);
  }
  cell_nodes_.resize(static_cast<size_t>(g.corners));
  for (int k = 0; k < g.nodes; ++k) {
    int64_t tag;
    if (binary_) tag = version4_ ? static_cast<int64_t>(binary<uint64_t>("node tag")) : binary<int32_t>("node tag");
    else tag = cursor_.parse_int<int64_t>("node tag");
    uint32_t index = node_index(tag, "element", elements_read_);
    if (k < g.corners) cell_nodes_[static_cast<size_t>(k)] = index;
  }
  if (g.corners < g.nodes && volume_corner_count(g.vtk_type, g.corners) > 0) ++batch.reduced;
  batch.push(static_cast<uint8_t>(g.vtk_type), cell_nodes_);
  if (physical != 0) tag_face(g.vtk_type, physical);
  if (!element_fields_.empty()) batch_tags_.push_back(element_tag);
  ++elements_read_;
  return true;
}

void GmshReader::tag_face(int vtk_type, int64_t physical) {
  if (vtk_type != kVtkTriangle && vtk_type != kVtkQuad) return;
  auto [it, added] = tag_of_physical_.try_emplace(physical, 0);
  if (added) {
    auto named = surface_names_.find(physical);
    it->second = face_tags_.tag(named != surface_names_.end() ? named->second : "physical " + std::to_string(physical));
  }
  const std::vector<uint32_t>& c = cell_nodes_;
  if (vtk_type == kVtkTriangle) {
    face_tags_.add(it->second, c[0], c[1], c[2]);
    return;
  }
  // a quad by the diagonal through its vertex of smallest id, as hexahedra are split
  size_t k = 0;
  for (size_t q = 1; q < 4; ++q)
    if (c[q] < c[k]) k = q;
  face_tags_.add(it->second, c[k], c[(k + 1) % 4], c[(k + 2) % 4]);
  face_tags_.add(it->second, c[k], c[(k + 2) % 4], c[(k + 3) % 4]);
}

// $PhysicalNames (ASCII in every file): dimension, tag and a quoted name a line.
void GmshReader::read_physical_names() {
  const uint64_t n = cursor_.parse_int<uint64_t>("physical name count");
  check_fits(cursor_, n, 6, "$PhysicalNames");
  for (uint64_t i = 0; i < n; ++i) {
    const int32_t dim = cursor_.parse_int<int32_t>("physical dimension");
    const int64_t tag = cursor_.parse_int<int64_t>("physical tag");
    std::string_view rest;
    if (!cursor_.line_text(rest)) cursor_.fail("$PhysicalNames ends inside its names");
    while (!rest.empty() && (rest.front() == ' ' || rest.front() == '\t')) rest.remove_prefix(1);
    while (!rest.empty() && (rest.back() == ' ' || rest.back() == '\t' || rest.back() == '\r')) rest.remove_suffix(1);
    if (rest.size() >= 2 && rest.front() == '"' && rest.back() == '"') rest = rest.substr(1, rest.size() - 2);
    if (rest.size() > 255) cursor_.fail("a physical name of " + std::to_string(rest.size()) + " characters (at most 255)");
    if (dim == 2) surface_names_[tag] = std::string(rest);
  }
  expect_end("PhysicalNames");
}

// MSH 4.1 $Entities: which physical surface each surface entity belongs to (its first
// physical tag); points, curves and volumes are read past.
void GmshReader::read_entities() {
  if (binary_) cursor_.skip_to_next_line();
  auto count = [&](const char* what) {
    const uint64_t n = binary_ ? binary<uint64_t>(what) : cursor_.parse_int<uint64_t>(what);
    check_fits(cursor_, n, 4, what);
    return n;
  };
  auto integer = [&](const char* what) { return binary_ ? binary<int32_t>(what) : cursor_.parse_int<int32_t>(what); };
  uint64_t n[4];
  for (uint64_t& k : n) k = count("entity count");
  for (int dim = 0; dim < 3; ++dim)
    for (uint64_t e = 0; e < n[dim]; ++e) {
      const int32_t tag = integer("entity tag");
      for (int k = 0; k < (dim == 0 ? 3 : 6); ++k) (void)(binary_ ? binary<double>("entity bounds") : cursor_.parse_double("entity bounds"));
      const uint64_t physicals = count("physical tag count");
      for (uint64_t p = 0; p < physicals; ++p) {
        const int32_t physical = integer("physical tag");
        if (dim == 2 && p == 0 && physical != 0) surface_physical_[tag] = physical < 0 ? -int64_t{physical} : physical;
      }
      if (dim == 0) continue;
      const uint64_t bounding = count("bounding entity count");
      for (uint64_t b = 0; b < bounding; ++b) integer("bounding entity");
    }
  skip_section("Entities");  // the volumes
}

bool GmshReader::read_cells(CellBatch& batch, size_t max_cells) {
  if (!elements_started_) {
    elements_started_ = true;
    cursor_.seek(elements_offset_, elements_line_);
    if (version4_) {
      if (binary_) cursor_.skip_to_next_line();
      blocks_left_ = count_value("element block count");
      elements_left_ = count_value("element count");
      count_value("minimum element tag");
      count_value("maximum element tag");
    } else {
      elements_left_ = cursor_.parse_int<uint64_t>("element count");
      if (binary_) cursor_.skip_to_next_line();
    }
    check_fits(cursor_, elements_left_, binary_ ? 8 : 4, "$Elements");
    header_.cell_count = elements_left_;
  }
  batch_tags_.clear();
  size_t added = 0;
  while (added < max_cells && next_element(batch)) ++added;
  if (added == 0 && elements_left_ == 0) return false;
  return added > 0;
}

void GmshReader::read_cell_values(size_t count, std::span<float* const> values, ReadStats&) {
  for (size_t a = 0; a < element_fields_.size(); ++a) {
    const ElementField& f = element_fields_[a];
    const size_t c = f.info.components;
    for (size_t i = 0; i < count && i < batch_tags_.size(); ++i) {
      auto at = std::lower_bound(f.tags.begin(), f.tags.end(), batch_tags_[i]);
      if (at == f.tags.end() || *at != batch_tags_[i]) {  // an element the field leaves out (often a surface's)
        std::fill_n(values[a] + i * c, c, std::numeric_limits<float>::quiet_NaN());
        continue;
      }
      std::copy_n(f.values.data() + static_cast<size_t>(at - f.tags.begin()) * c, c, values[a] + i * c);
    }
  }
}

void GmshReader::rewind_cells() {
  face_tags_ = {};  // met again on the next pass
  tag_of_physical_.clear();
  elements_started_ = false;
  elements_left_ = block_left_ = blocks_left_ = 0;
  elements_read_ = 0;
  batch_tags_.clear();
}

}  // namespace

std::unique_ptr<FormatReader> make_gmsh_reader(std::shared_ptr<InputFile> file, int64_t time_step) {
  return std::make_unique<GmshReader>(std::move(file), time_step);
}

}  // namespace tetrascope::storage::detail
