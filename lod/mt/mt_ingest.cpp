// Stage 1 of `tetrascope preprocess`: the input's vertices in one table that later levels
// extend, the normalisation of every attribute (histogram channels, simplifier ranges), and
// the tets as they stream in: in memory, or for a mesh over the memory budget in a spill file,
// so that level 0 is never whole in memory.
#include <algorithm>
#include <cmath>
#include <limits>

#include "mt_stages.h"
#include "tetrascope/storage/mesh_stream.h"
#include "tetrascope/core/vec3.h"

namespace tetrascope::lod::mt {
namespace {

// Channels and simplifier ranges from the table's input values.
void add_channels(IngestedMesh& out) {
  const uint32_t n0 = out.input_vertices;
  const VertexTable& table = out.table;
  uint32_t base = 0;
  for (const auto& info : out.attributes) {
    const uint32_t c = info.components;
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    std::vector<std::array<double, 2>> components(c > 1 ? c : 0, std::array<double, 2>{lo, hi});
    for (uint32_t v = 0; v < n0; ++v) {
      const float* value = &table.values[size_t{v} * table.floats + base];
      double m = 0;
      for (uint32_t k = 0; k < c; ++k) m += double(value[k]) * value[k];
      for (uint32_t k = 0; k < components.size(); ++k)
        if (std::isfinite(value[k])) components[k] = {std::min<double>(components[k][0], value[k]), std::max<double>(components[k][1], value[k])};
      m = c == 1 ? double(value[0]) : std::sqrt(m);
      if (!std::isfinite(m)) continue;
      lo = std::min(lo, m);
      hi = std::max(hi, m);
    }
    if (!std::isfinite(lo)) lo = hi = 0;
    out.channels.offset.push_back(base);
    out.channels.components.push_back(c);
    out.channels.lo.push_back(c == 1 ? lo : 0);
    out.channels.scale.push_back(c == 1 ? (hi > lo ? 1 / (hi - lo) : 0) : (hi > 0 ? 1 / hi : 0));
    out.ranges.push_back(c == 1 ? std::array<double, 2>{lo, hi} : std::array<double, 2>{0, hi});
    for (auto& r : components)
      if (!std::isfinite(r[0])) r = {0, 0};
    out.component_ranges.push_back(std::move(components));
    base += c;
  }
}

// Removes the vertices no tet uses from the table and renumbers the tets (a file may hold
// millions of points and one tet). Returns how many were removed.
uint64_t drop_unused(IngestedMesh& out, const std::vector<uint8_t>& used) {
  VertexTable& table = out.table;
  const size_t count = table.size();
  std::vector<uint32_t> renumber(count, kNone);
  uint32_t kept = 0;
  for (size_t v = 0; v < count; ++v)
    if (used[v]) renumber[v] = kept++;
  if (kept == count) return 0;
  out.face_tags.renumber(renumber, kNone);
  for (size_t v = 0; v < count; ++v) {
    if (renumber[v] == kNone || renumber[v] == v) continue;
    std::copy_n(table.xyz.begin() + static_cast<std::ptrdiff_t>(3 * v), 3, table.xyz.begin() + static_cast<std::ptrdiff_t>(3 * size_t{renumber[v]}));
    std::copy_n(table.values.begin() + static_cast<std::ptrdiff_t>(v * table.floats), table.floats,
                table.values.begin() + static_cast<std::ptrdiff_t>(size_t{renumber[v]} * table.floats));
    out.vertex_volume[renumber[v]] = out.vertex_volume[v];
  }
  out.vertex_volume.resize(kept);
  out.vertex_volume.shrink_to_fit();
  table.xyz.resize(3 * size_t{kept});
  table.xyz.shrink_to_fit();
  table.values.resize(size_t{kept} * table.floats);
  table.values.shrink_to_fit();
  // the tets, a chunk at a time
  constexpr uint64_t kChunk = 1 << 16;
  std::vector<uint32_t> buffer, renumbered;
  for (uint64_t begin = 0; begin < out.tets.tet_count(0); begin += kChunk) {
    const uint64_t n = std::min(kChunk, out.tets.tet_count(0) - begin);
    const std::span<const uint32_t> ids = out.tets.read(0, begin, n, buffer);
    renumbered.resize(ids.size());
    for (size_t i = 0; i < ids.size(); ++i) renumbered[i] = renumber[ids[i]];
    out.tets.write(0, begin, renumbered);
  }
  return count - kept;
}

// tet volumes binned by log2 at eighth steps, 2^-160 to 2^+160 (clamped at the ends)
constexpr int kLogVolumeSteps = 8, kLogVolumeLow = -160;
constexpr size_t kLogVolumeBins = size_t{320} * kLogVolumeSteps;

size_t log_volume_bin(double volume) {
  const double at = std::floor((std::log2(volume) - kLogVolumeLow) * kLogVolumeSteps);
  return static_cast<size_t>(std::clamp(at, 0.0, double(kLogVolumeBins - 1)));
}

// the 90th over the 10th percentile of the tets' size (cube root of volume)
double size_spread(const std::vector<uint64_t>& log_volume) {
  uint64_t total = 0;
  for (uint64_t n : log_volume) total += n;
  if (total == 0) return 1;
  auto percentile = [&](double p) {
    const double wanted = p * double(total);
    uint64_t seen = 0;
    for (size_t b = 0; b < log_volume.size(); ++b)
      if (double(seen += log_volume[b]) >= wanted) return double(b);
    return double(log_volume.size() - 1);
  };
  return std::exp2((percentile(0.9) - percentile(0.1)) / (3.0 * kLogVolumeSteps));
}

}  // namespace

IngestedMesh ingest_mesh(const std::filesystem::path& mesh_path, const PreprocessOptions& options, const std::filesystem::path& spill_directory) {
  IngestedMesh out;
  auto stream = storage::MeshStream::open(mesh_path, options.read_limits);
  const storage::MeshHeader& header = stream->header();
  VertexTable& table = out.table;
  for (const auto& info : header.attributes) {
    out.attributes.push_back(info);
    table.floats += info.components;
  }
  table.values.reserve(header.vertex_count * table.floats);
  storage::VertexChunk vertices;
  while (stream->next_vertices(vertices)) {
    const size_t at = table.values.size();
    table.values.resize(at + vertices.count * table.floats);
    uint32_t base = 0;
    for (size_t a = 0; a < vertices.attributes.size(); ++a) {
      const uint32_t c = out.attributes[a].components;
      for (size_t v = 0; v < vertices.count; ++v)
        for (uint32_t k = 0; k < c; ++k) table.values[at + v * table.floats + base + k] = vertices.attributes[a][v * c + k];
      base += c;
    }
  }
  for (size_t a = 0; a < out.attributes.size(); ++a) out.attributes[a] = header.attributes[a];  // tensors' flags, known now
  const std::span<const float> xyz = stream->xyz();
  table.xyz.assign(xyz.begin(), xyz.end());
  if (table.size() >= 0x7FFFFFFFu) throw std::runtime_error(mesh_path.string() + ": too many vertices for one store");

  // the tets as they come, in memory or spilled (the file's cells bound its tets loosely)
  out.spill_directory = spill_directory;
  out.tets = NodeTets(spill_directory);
  out.tets.add(0, uint64_t{0}, spill_level(header.cell_count, options));
  std::vector<uint8_t> used(table.size(), 0);
  std::vector<float>& volume = out.vertex_volume;
  volume.assign(table.size(), 0.0f);
  std::vector<uint64_t> log_volume(kLogVolumeBins, 0);
  storage::TetChunk chunk;
  while (stream->next_tets(chunk)) {
    for (uint32_t v : chunk.tets) used[v] = 1;
    for (size_t t = 0; t + 3 < chunk.tets.size(); t += 4) {
      Vec3 p[4];
      for (int k = 0; k < 4; ++k) {
        const float* at = &table.xyz[3 * size_t{chunk.tets[t + size_t(k)]}];
        p[k] = {at[0], at[1], at[2]};
      }
      const double quarter = std::fabs(dot(cross(p[1] - p[0], p[2] - p[0]), p[3] - p[0])) / 24;
      if (std::isfinite(quarter) && quarter > 0) {
        for (int k = 0; k < 4; ++k) volume[chunk.tets[t + size_t(k)]] += static_cast<float>(quarter);
        ++log_volume[log_volume_bin(4 * quarter)];
      }
    }
    out.tets.append(chunk.tets);
  }
  out.read_stats = stream->stats();
  out.face_tags = stream->face_tags();
  stream.reset();
  out.input_tets = out.tets.tet_count(0);
  if (out.input_tets == 0) throw std::runtime_error(mesh_path.string() + ": the mesh has no tetrahedra");
  out.grading = size_spread(log_volume);
  out.dropped_unused_vertices = drop_unused(out, used);
  out.input_vertices = static_cast<uint32_t>(table.size());
  add_channels(out);

  storage::Bounds& bounds = out.bounds;
  for (int k = 0; k < 3; ++k) {
    float lo = std::numeric_limits<float>::max(), hi = std::numeric_limits<float>::lowest();
    for (size_t v = 0; v < table.size(); ++v) {
      lo = std::min(lo, table.xyz[3 * v + size_t(k)]);
      hi = std::max(hi, table.xyz[3 * v + size_t(k)]);
    }
    bounds.min[size_t(k)] = lo;
    bounds.max[size_t(k)] = hi;
  }
  out.diagonal = std::max(1e-30, std::sqrt(std::pow(bounds.max[0] - bounds.min[0], 2) + std::pow(bounds.max[1] - bounds.min[1], 2) +
                                           std::pow(bounds.max[2] - bounds.min[2], 2)));
  return out;
}

}  // namespace tetrascope::lod::mt
