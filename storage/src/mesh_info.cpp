#include "tetrascope/storage/mesh_info.h"

#include <chrono>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <limits>

#include "tetrascope/storage/tensor.h"

namespace tetrascope::storage {

MeshSummary summarize_stream(MeshStream& stream) {
  MeshSummary s;
  s.header = stream.header();
  for (const AttributeInfo& info : s.header.attributes) {
    AttributeSummary a;
    a.info = info;
    a.min = std::numeric_limits<double>::infinity();
    a.max = -std::numeric_limits<double>::infinity();
    a.component_ranges.assign(info.components, {a.min, a.max});
    s.attributes.push_back(a);
  }
  std::array<double, 3> lo{std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()};
  std::array<double, 3> hi{-lo[0], -lo[1], -lo[2]};
  VertexChunk chunk;
  while (stream.next_vertices(chunk)) {
    for (size_t i = 0; i < chunk.count; ++i) {
      const float p[3] = {chunk.x[i], chunk.y[i], chunk.z[i]};
      for (int k = 0; k < 3; ++k) {
        lo[k] = std::min<double>(lo[k], p[k]);
        hi[k] = std::max<double>(hi[k], p[k]);
      }
    }
    for (size_t a = 0; a < chunk.attributes.size(); ++a) {
      AttributeSummary& sum = s.attributes[a];
      const uint32_t c = sum.info.components;
      const float* v = chunk.attributes[a].data();
      for (size_t i = 0; i < chunk.count; ++i) {
        double magnitude2 = 0;
        bool finite = true;
        for (uint32_t k = 0; k < c; ++k) {
          double x = v[i * c + k];
          if (!std::isfinite(x)) {
            finite = false;
            continue;
          }
          auto& r = sum.component_ranges[k];
          r[0] = std::min(r[0], x);
          r[1] = std::max(r[1], x);
          magnitude2 += x * x;
        }
        if (!finite) {
          ++sum.nonfinite;
          continue;
        }
        double value = c == 1 ? double(v[i]) : std::sqrt(magnitude2);
        sum.min = std::min(sum.min, value);
        sum.max = std::max(sum.max, value);
      }
    }
  }
  s.header = stream.header();  // tensors' flags are known once every vertex was read
  for (size_t a = 0; a < s.attributes.size(); ++a) s.attributes[a].info = s.header.attributes[a];
  TetChunk tets;
  while (stream.next_tets(tets)) {
  }
  s.stats = stream.stats();
  const FaceTags& tags = stream.face_tags();
  for (const std::string& name : tags.names) s.face_tags.push_back({name, 0});
  for (uint32_t t : tags.tags) ++s.face_tags[t].second;
  if (s.header.vertex_count > 0) {
    s.bounds.min = lo;
    s.bounds.max = hi;
  }
  return s;
}

MeshSummary summarize_mesh(const std::filesystem::path& path) {
  auto start = std::chrono::steady_clock::now();
  auto stream = MeshStream::open(path);
  MeshSummary s = summarize_stream(*stream);
  s.read_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  s.file = path.string();
  std::error_code ec;
  s.file_bytes = std::filesystem::is_regular_file(path, ec) ? std::filesystem::file_size(path, ec) : 0;  // 0 for a case folder
  if (s.header.format == MeshFormat::kTetgen) {
    std::filesystem::path node = path, ele = path;
    s.file_bytes = std::filesystem::file_size(node.replace_extension(".node"), ec) + std::filesystem::file_size(ele.replace_extension(".ele"), ec);
  }
  return s;
}

namespace {
nlohmann::json number(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }
}  // namespace

nlohmann::json summary_json(const MeshSummary& s) {
  nlohmann::json j;
  j["file"] = s.file;
  j["format"] = format_name(s.header.format);
  j["description"] = s.header.description;
  j["file_bytes"] = s.file_bytes;
  j["vertices"] = s.header.vertex_count;
  j["tetrahedra"] = s.stats.tetrahedra;
  j["cells"] = {{"total", s.header.cell_count}, {"volume", s.stats.cells}, {"hexahedra", s.stats.hexahedra},
                {"wedges", s.stats.wedges}, {"pyramids", s.stats.pyramids}, {"polyhedra", s.stats.polyhedra}, {"higher_order", s.stats.quadratic_cells},
                {"skipped", s.stats.skipped_cells}};
  nlohmann::json attributes = nlohmann::json::array();
  const size_t points = s.header.point_attribute_count();
  for (size_t k = 0; k < s.attributes.size(); ++k) {
    const AttributeSummary& a = s.attributes[k];
    nlohmann::json ranges = nlohmann::json::array();
    for (auto r : a.component_ranges) ranges.push_back({number(r[0]), number(r[1])});
    attributes.push_back({{"name", a.info.name}, {"components", a.info.components}, {"min", number(a.min)}, {"max", number(a.max)},
                          {"range_of", a.info.components == 1 ? "value" : "magnitude"}, {"component_ranges", ranges},
                          {"nonfinite", a.nonfinite}, {"association", k < points ? "point" : "cell"}});
    if (k >= points) attributes.back()["cell_name"] = s.header.cell_attributes[k - points].name;
    add_attribute_kind_json(attributes.back(), a.info);
  }
  j["attributes"] = attributes;
  j["bounds"] = {{"min", {s.bounds.min[0], s.bounds.min[1], s.bounds.min[2]}}, {"max", {s.bounds.max[0], s.bounds.max[1], s.bounds.max[2]}}};
  j["quality"] = {{"degenerate", s.stats.degenerate}, {"inverted", s.stats.inverted}, {"repeated_vertex_dropped", s.stats.repeated_vertex}};
  nlohmann::json tags = nlohmann::json::array();
  for (size_t t = 0; t < s.face_tags.size(); ++t) tags.push_back({{"tag", t}, {"name", s.face_tags[t].first}, {"triangles", s.face_tags[t].second}});
  j["face_tags"] = tags;
  j["regions_source"] = s.face_tags.empty() ? "sharp edges" : "input tags";
  j["step_times"] = s.header.step_times;
  j["warnings"] = s.stats.warnings;
  j["read_seconds"] = s.read_seconds;
  return j;
}

namespace {
__attribute__((format(printf, 2, 3))) void appendf(std::string& out, const char* format, ...) {
  char line[512];
  va_list args;
  va_start(args, format);
  std::vsnprintf(line, sizeof line, format, args);
  va_end(args);
  out += line;
}
}  // namespace

std::string summary_text(const MeshSummary& s) {
  std::string out;
  appendf(out, "file        %s (%s, %.1f MB)\n", s.file.c_str(), s.header.description.c_str(), s.file_bytes / 1e6);
  appendf(out, "vertices    %llu\n", static_cast<unsigned long long>(s.header.vertex_count));
  appendf(out, "tetrahedra  %llu", static_cast<unsigned long long>(s.stats.tetrahedra));
  if (s.stats.cells != s.stats.tetrahedra) appendf(out, "  (from %llu volume cells)", static_cast<unsigned long long>(s.stats.cells));
  appendf(out, "\n");
  if (s.stats.hexahedra + s.stats.wedges + s.stats.pyramids > 0) {
    appendf(out, "split       %llu hexahedra, %llu wedges, %llu pyramids\n", static_cast<unsigned long long>(s.stats.hexahedra),
        static_cast<unsigned long long>(s.stats.wedges), static_cast<unsigned long long>(s.stats.pyramids));
  }
  if (s.stats.polyhedra) appendf(out, "decomposed  %llu polyhedra about their centres\n", static_cast<unsigned long long>(s.stats.polyhedra));
  if (s.stats.quadratic_cells) appendf(out, "higher-order cells reduced to corners: %llu\n", static_cast<unsigned long long>(s.stats.quadratic_cells));
  if (s.stats.skipped_cells) appendf(out, "skipped     %llu points/lines/surface cells\n", static_cast<unsigned long long>(s.stats.skipped_cells));
  appendf(out, "bounds      [%g, %g] x [%g, %g] x [%g, %g]\n", s.bounds.min[0], s.bounds.max[0], s.bounds.min[1], s.bounds.max[1], s.bounds.min[2], s.bounds.max[2]);
  appendf(out, "attributes  %zu\n", s.attributes.size());
  for (size_t k = 0; k < s.attributes.size(); ++k) {
    const AttributeSummary& a = s.attributes[k];
    appendf(out, "  %-24s %s  %g .. %g%s%s\n", a.info.name.c_str(), attribute_kind_text(a.info).c_str(),
        a.min, a.max, a.info.components == 1 ? "" : " (magnitude)", k < s.header.point_attribute_count() ? "" : "  (cell data, volume-weighted at the vertices)");
  }
  appendf(out, "degenerate  %llu tets of zero volume\n", static_cast<unsigned long long>(s.stats.degenerate));
  appendf(out, "inverted    %llu tets re-oriented\n", static_cast<unsigned long long>(s.stats.inverted));
  if (s.face_tags.empty()) appendf(out, "regions     from sharp edges (the input tags no boundary face)\n");
  else appendf(out, "regions     from the input's %zu face tags:\n", s.face_tags.size());
  for (size_t t = 0; t < s.face_tags.size(); ++t)
    appendf(out, "  tag %-4zu %-24s %llu triangles\n", t, s.face_tags[t].first.c_str(), static_cast<unsigned long long>(s.face_tags[t].second));
  if (s.header.step_times.size() > 1) {
    appendf(out, "time steps  %zu, t = %g .. %g (one read; preprocess --all-steps makes a series of them all)\n", s.header.step_times.size(), s.header.step_times.front(),
            s.header.step_times.back());
  }
  for (const std::string& w : s.stats.warnings) appendf(out, "warning     %s\n", w.c_str());
  appendf(out, "read time   %.3f s\n", s.read_seconds);
  return out;
}

}  // namespace tetrascope::storage
