#include "tetrascope/storage/mesh_stream.h"

#include <algorithm>
#include <cmath>
#include <thread>

#include "cell_split.h"
#include "format_reader.h"
#include "tensor_stream.h"

namespace tetrascope::storage {

using detail::CellBatch;

struct MeshStream::CellScratch {
  CellBatch batch;
};

const char* format_name(MeshFormat format) {
  switch (format) {
    case MeshFormat::kVtkLegacy: return "vtk";
    case MeshFormat::kVtu: return "vtu";
    case MeshFormat::kGmsh: return "msh";
    case MeshFormat::kTetgen: return "tetgen";
    case MeshFormat::kOff: return "off";
    case MeshFormat::kExodus: return "exodus";
    case MeshFormat::kOpenFoam: return "openfoam";
    case MeshFormat::kCgns: return "cgns";
  }
  return "?";
}

bool is_openfoam_time_folder(const std::filesystem::path& path) {
  std::error_code ec;
  const std::string name = path.filename().string();
  char* end = nullptr;
  const double t = std::strtod(name.c_str(), &end);
  return !name.empty() && end && *end == '\0' && std::isfinite(t) && std::filesystem::is_directory(path, ec) &&
         std::filesystem::is_directory(path.parent_path() / "constant" / "polyMesh", ec);
}

std::filesystem::path fingerprinted_file(const std::filesystem::path& path) {
  std::error_code ec;
  const MeshFormat format = format_from_path(path);
  std::filesystem::path hashed = path;
  if (format == MeshFormat::kTetgen) hashed.replace_extension(".ele");
  if (format == MeshFormat::kOpenFoam && std::filesystem::is_directory(path, ec)) {
    const std::filesystem::path mesh = (is_openfoam_time_folder(path) ? path.parent_path() : path) / "constant" / "polyMesh";
    hashed = std::filesystem::exists(mesh / "points", ec) ? mesh / "points" : mesh / "points.gz";
  }
  return hashed;
}

MeshFormat format_from_path(const std::filesystem::path& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path / "constant" / "polyMesh", ec)) return MeshFormat::kOpenFoam;
  if (is_openfoam_time_folder(path)) return MeshFormat::kOpenFoam;  // one time step of a case
  std::string ext = path.extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (ext == ".vtk") return MeshFormat::kVtkLegacy;
  if (ext == ".vtu") return MeshFormat::kVtu;
  if (ext == ".msh") return MeshFormat::kGmsh;
  if (ext == ".node" || ext == ".ele") return MeshFormat::kTetgen;
  if (ext == ".off") return MeshFormat::kOff;
  if (ext == ".foam" || ext == ".openfoam") return MeshFormat::kOpenFoam;
  if (ext == ".cgns" || ext == ".adf") return MeshFormat::kCgns;
  if (ext == ".exo" || ext == ".e" || ext == ".ex2" || ext == ".exii" || ext == ".g" || ext == ".gen") return MeshFormat::kExodus;
  throw MeshError(path.string() + ": unknown mesh format '" + ext +
                  "' (expected .vtk, .vtu, .msh, .node/.ele, .off, Exodus II .exo/.e/.ex2/.exii/.g/.gen, CGNS .cgns/.adf or an OpenFOAM case)");
}

uint64_t ReadLimits::max_inflated_bytes(uint64_t file_bytes) const {
  const double allowed = static_cast<double>(kInflateAllowanceBytes) + max_inflate_ratio * static_cast<double>(file_bytes);
  return allowed >= 1.8e19 ? UINT64_MAX : static_cast<uint64_t>(allowed);
}

std::unique_ptr<MeshStream> MeshStream::open(const std::filesystem::path& path, const ReadLimits& limits) {
  MeshFormat format = format_from_path(path);
  std::unique_ptr<detail::FormatReader> reader;
  auto open_file = [&](const std::filesystem::path& p) { return detail::InputFile::open(p, limits); };
  switch (format) {
    case MeshFormat::kVtkLegacy: reader = detail::make_vtk_legacy_reader(open_file(path)); break;
    case MeshFormat::kVtu: reader = detail::make_vtu_reader(open_file(path)); break;
    case MeshFormat::kGmsh: reader = detail::make_gmsh_reader(open_file(path), limits.time_step); break;
    case MeshFormat::kOff: reader = detail::make_off_reader(open_file(path)); break;
    case MeshFormat::kExodus: reader = detail::make_exodus_reader(path, limits); break;  // refuses when built without the library
    case MeshFormat::kOpenFoam: reader = detail::make_openfoam_reader(path, limits); break;
    case MeshFormat::kCgns: reader = detail::make_cgns_reader(path, limits); break;  // refuses when built without the library
    case MeshFormat::kTetgen: {
      std::filesystem::path node = path, ele = path;
      node.replace_extension(".node");
      ele.replace_extension(".ele");
      reader = detail::make_tetgen_reader(open_file(node), open_file(ele));
      break;
    }
  }
  return std::unique_ptr<MeshStream>(new MeshStream(std::move(reader)));
}

std::unique_ptr<MeshStream> MeshStream::open_memory(MeshFormat format, std::string name, std::span<const char> bytes,
                                                    std::span<const char> second_bytes, const ReadLimits& limits) {
  auto file = detail::InputFile::from_memory(name, bytes, limits);
  std::unique_ptr<detail::FormatReader> reader;
  switch (format) {
    case MeshFormat::kVtkLegacy: reader = detail::make_vtk_legacy_reader(file); break;
    case MeshFormat::kVtu: reader = detail::make_vtu_reader(file); break;
    case MeshFormat::kGmsh: reader = detail::make_gmsh_reader(file, limits.time_step); break;
    case MeshFormat::kOff: reader = detail::make_off_reader(file); break;
    case MeshFormat::kExodus: throw MeshError(name + ": Exodus II is read from files, not from memory");
    case MeshFormat::kOpenFoam: throw MeshError(name + ": an OpenFOAM case is read from its folder, not from memory");
    case MeshFormat::kCgns: throw MeshError(name + ": CGNS is read from files, not from memory");
    case MeshFormat::kTetgen:
      reader = detail::make_tetgen_reader(file, detail::InputFile::from_memory(name + ".ele", second_bytes));
      break;
  }
  return std::unique_ptr<MeshStream>(new MeshStream(std::move(reader)));
}

MeshStream::MeshStream(std::unique_ptr<detail::FormatReader> reader)
    : reader_(std::move(reader)), cells_(std::make_unique<CellScratch>()) {
  header_ = reader_->index(stats_);
  // Counts were checked against the file size by the reader, so this allocation is bounded
  // by the input, not by what a header claims.
  xyz_.reserve(3 * header_.vertex_count);
  for (AttributeInfo info : header_.cell_attributes) {
    bool taken = false;
    for (const AttributeInfo& a : header_.attributes) taken |= a.name == info.name;
    if (taken) {
      stats_.warnings.push_back("cell data '" + info.name + "' is named '" + info.name + "_cells' (a point array has its name)");
      info.name += "_cells";
    }
    header_.attributes.push_back(std::move(info));
  }
  attribute_scratch_.resize(header_.attributes.size());
  tensors_ = std::make_unique<detail::TensorExpansion>();
  public_header_ = tensors_->plan(header_, stats_);
}

MeshStream::~MeshStream() = default;

bool MeshStream::next_vertices(VertexChunk& chunk, size_t max_vertices) {
  if (vertices_read_ >= header_.vertex_count) return false;
  if (!header_.cell_attributes.empty() && !cell_data_converted_) convert_cell_data();
  size_t count = static_cast<size_t>(std::min<uint64_t>(std::max<size_t>(max_vertices, 1), header_.vertex_count - vertices_read_));
  chunk.attributes.clear();
  const size_t base = 3 * static_cast<size_t>(vertices_read_);
  if (cell_data_converted_) {  // every vertex was read: serve the held values
    for (size_t a = 0; a < header_.attributes.size(); ++a) {
      const size_t c = header_.attributes[a].components;
      chunk.attributes.emplace_back(held_attributes_[a].data() + vertices_read_ * c, count * c);
    }
  } else {
    std::vector<float*> attribute_pointers;
    for (size_t a = 0; a < header_.attributes.size(); ++a) {
      attribute_scratch_[a].resize(count * header_.attributes[a].components);
      attribute_pointers.push_back(attribute_scratch_[a].data());
    }
    // Coordinates stay interleaved: orienting a tet then touches one cache line a vertex.
    xyz_.resize(base + 3 * count);
    reader_->read_vertices(count, xyz_.data() + base, attribute_pointers, stats_);
    for (const auto& a : attribute_scratch_) chunk.attributes.emplace_back(a);
  }
  soa_scratch_.resize(3 * count);
  for (size_t i = 0; i < count; ++i) {
    soa_scratch_[i] = xyz_[base + 3 * i];
    soa_scratch_[count + i] = xyz_[base + 3 * i + 1];
    soa_scratch_[2 * count + i] = xyz_[base + 3 * i + 2];
  }
  if (tensors_->active()) tensors_->expand(count, chunk.attributes);
  chunk.first = vertices_read_;
  chunk.count = count;
  chunk.x = std::span<const float>(soa_scratch_).subspan(0, count);
  chunk.y = std::span<const float>(soa_scratch_).subspan(count, count);
  chunk.z = std::span<const float>(soa_scratch_).subspan(2 * count, count);
  vertices_read_ += count;
  if (vertices_read_ == header_.vertex_count && tensors_->active()) tensors_->finish(public_header_, stats_);
  return true;
}

namespace {
// Returns 6 * signed volume, and whether it is numerically zero relative to the edges.
double orientation(const float* xyz, const uint32_t* t, bool& degenerate) {
  const float* p0 = xyz + 3 * size_t{t[0]};
  const float* p1 = xyz + 3 * size_t{t[1]};
  const float* p2 = xyz + 3 * size_t{t[2]};
  const float* p3 = xyz + 3 * size_t{t[3]};
  double ax = double(p1[0]) - p0[0], ay = double(p1[1]) - p0[1], az = double(p1[2]) - p0[2];
  double bx = double(p2[0]) - p0[0], by = double(p2[1]) - p0[1], bz = double(p2[2]) - p0[2];
  double cx = double(p3[0]) - p0[0], cy = double(p3[1]) - p0[1], cz = double(p3[2]) - p0[2];
  double det = ax * (by * cz - bz * cy) - ay * (bx * cz - bz * cx) + az * (bx * cy - by * cx);
  // |det| <= 1e-12 |a||b||c|, squared to avoid the square root
  double scale2 = (ax * ax + ay * ay + az * az) * (bx * bx + by * by + bz * bz) * (cx * cx + cy * cy + cz * cz);
  degenerate = det * det <= 1e-24 * scale2;
  return det;
}
// Makes the tet positively oriented in place and counts what it found.
void orient(const float* xyz, uint32_t* tet, ReadStats& stats, bool count_inversion) {
  bool degenerate = false;
  double det = orientation(xyz, tet, degenerate);
  if (degenerate) {
    ++stats.degenerate;
  } else if (det < 0) {
    std::swap(tet[2], tet[3]);
    if (count_inversion) ++stats.inverted;
  }
}
// The linear cell a volume cell of `corners` corners is split as.
int linear_type(int type, int corners) {
  if (corners == 4) return detail::kVtkTetra;
  if (corners == 8) return type == detail::kVtkVoxel ? detail::kVtkVoxel : detail::kVtkHexahedron;
  if (corners == 6) return detail::kVtkWedge;
  if (corners == 5) return detail::kVtkPyramid;
  return type;
}
// The volume of a volume cell: the sum of its tets' (a hexahedron's, wedge's or pyramid's as
// split for the mesh).
double cell_volume(const float* xyz, int type, int corners, std::span<const uint32_t> nodes) {
  uint32_t tets[4 * 6];
  const size_t n = corners == 4 ? 1 : detail::split_cell(linear_type(type, corners), nodes.first(static_cast<size_t>(corners)), tets);
  if (corners == 4) std::copy_n(nodes.data(), 4, tets);
  double volume = 0;
  for (size_t t = 0; t < n; ++t) {
    bool degenerate = false;
    volume += std::fabs(orientation(xyz, tets + 4 * t, degenerate)) / 6;
  }
  return volume;
}
}  // namespace

void MeshStream::convert_cell_data() {
  const size_t V = static_cast<size_t>(header_.vertex_count), P = header_.point_attribute_count();
  held_attributes_.resize(header_.attributes.size());
  for (size_t a = 0; a < header_.attributes.size(); ++a) held_attributes_[a].resize(V * header_.attributes[a].components);
  xyz_.resize(3 * V);
  std::vector<float*> pointers(P);
  for (size_t first = 0; first < V; first += kDefaultChunk) {
    const size_t count = std::min(kDefaultChunk, V - first);
    for (size_t a = 0; a < P; ++a) pointers[a] = held_attributes_[a].data() + first * header_.attributes[a].components;
    reader_->read_vertices(count, xyz_.data() + 3 * first, pointers, stats_);
  }
  size_t floats = 0;
  for (const AttributeInfo& info : header_.cell_attributes) floats += info.components;
  std::vector<double> sums(V * floats, 0.0), weights(V, 0.0);
  std::vector<uint8_t> marks(V, 0);  // vertices of a volume cell
  accumulate_cell_data(sums, weights, marks, false);
  reader_->rewind_cells();
  // a vertex whose volume cells all have zero volume: their plain mean (one more pass, only then)
  bool any_flat = false;
  for (size_t v = 0; v < V; ++v) {
    marks[v] = marks[v] && weights[v] == 0;
    any_flat |= marks[v] != 0;
  }
  if (any_flat) {
    const uint64_t counted = stats_.nonfinite_attribute_values;  // the values were counted once
    accumulate_cell_data(sums, weights, marks, true);
    reader_->rewind_cells();
    stats_.nonfinite_attribute_values = counted;
  }
  uint64_t alone = 0;
  for (size_t v = 0; v < V; ++v) alone += weights[v] == 0;
  for (size_t k = 0, offset = 0; k < header_.cell_attributes.size(); ++k) {
    const uint32_t c = header_.cell_attributes[k].components;
    float* out = held_attributes_[P + k].data();
    for (size_t v = 0; v < V; ++v)
      for (uint32_t j = 0; j < c; ++j) out[v * c + j] = weights[v] > 0 ? static_cast<float>(sums[v * floats + offset + j] / weights[v]) : 0.0f;
    offset += c;
  }
  if (alone > 0) stats_.warnings.push_back(std::to_string(alone) + " vertices in no volume cell take 0 for the cell data");
  cell_data_converted_ = true;
}

// One pass over the cells: Σ weight·value and Σ weight at each volume cell's corners. The
// weight is the cell's volume, and `marks` gets every corner; with `plain`, the weight is 1 at
// the vertices `marks` holds and 0 elsewhere.
void MeshStream::accumulate_cell_data(std::vector<double>& sums, std::vector<double>& weights, std::vector<uint8_t>& marks, bool plain) {
  const size_t K = header_.cell_attributes.size(), floats = sums.size() / std::max<size_t>(weights.size(), 1);
  std::vector<std::vector<float>> values(K);
  std::vector<float*> pointers(K);
  std::vector<uint32_t> corners_scratch;
  CellBatch& batch = cells_->batch;
  for (;;) {
    batch.clear();
    if (!reader_->read_cells(batch, kDefaultChunk)) break;
    const size_t n = batch.size();
    for (size_t k = 0; k < K; ++k) {
      values[k].resize(n * header_.cell_attributes[k].components);
      pointers[k] = values[k].data();
    }
    reader_->read_cell_values(n, pointers, stats_);
    for (size_t c = 0, end = 0; c < n; c = end) {
      // a cell and the pieces that continue it (one decomposed polyhedron)
      for (end = c + 1; end < n && batch.continues(end);) ++end;
      double volume = 0;
      corners_scratch.clear();
      for (size_t e = c; e < end; ++e) {
        const size_t node_count = batch.offsets[e + 1] - batch.offsets[e];
        const std::span<const uint32_t> nodes(batch.nodes.data() + batch.offsets[e], node_count);
        const int corners = detail::volume_corner_count(batch.types[e], static_cast<int>(node_count));
        if (corners <= 0) continue;
        if (!plain) volume += cell_volume(xyz_.data(), batch.types[e], corners, nodes);
        corners_scratch.insert(corners_scratch.end(), nodes.begin(), nodes.begin() + corners);
      }
      std::sort(corners_scratch.begin(), corners_scratch.end());
      corners_scratch.erase(std::unique(corners_scratch.begin(), corners_scratch.end()), corners_scratch.end());
      for (const uint32_t v : corners_scratch) {
        if (!plain) marks[v] = 1;
        const double w = plain ? double(marks[v]) : volume;
        if (w == 0) continue;
        weights[v] += w;
        for (size_t k = 0, offset = 0; k < K; ++k) {
          const uint32_t components = header_.cell_attributes[k].components;
          for (uint32_t j = 0; j < components; ++j) sums[size_t{v} * floats + offset + j] += w * values[k][c * components + j];
          offset += components;
        }
      }
    }
  }
}

void MeshStream::take_face_tags() {
  face_tags_ = reader_->take_face_tags();
  // the readers check every vertex id; a tag past the names would be a reader's slip
  for (uint32_t t : face_tags_.tags)
    if (t >= face_tags_.names.size()) throw MeshError("a boundary face tag has no name");
  if (face_tags_.names.size() > kMaxFaceTags) {
    stats_.warnings.push_back(std::to_string(face_tags_.names.size()) + " boundary face tags are more than tetrascope keeps (" + std::to_string(kMaxFaceTags) +
                              "): none kept, boundary regions come from sharp edges");
    face_tags_ = {};
  }
}

bool MeshStream::next_tets(TetChunk& chunk, size_t max_tets) {
  VertexChunk drain;
  while (next_vertices(drain)) {
  }
  max_tets = std::max<size_t>(max_tets, 6);
  tet_scratch_.clear();
  split_scratch_.clear();
  // a chunk whose every tet repeats a vertex is empty: read on until one survives or cells end
  for (;;) {
    fill_tet_chunk(max_tets);
    drop_repeated_vertex_tets();
    if (!tet_scratch_.empty() || cells_done_) break;
  }
  if (tet_scratch_.empty()) {
    if (stats_.repeated_vertex > 0 && !repeated_vertex_warned_) {
      repeated_vertex_warned_ = true;
      stats_.warnings.push_back(std::to_string(stats_.repeated_vertex) +
                                " tetrahedra that repeat a vertex (no volume, no faces) were dropped");
    }
    return false;
  }
  orient_chunk();
  chunk.first = tets_emitted_;
  chunk.count = tet_scratch_.size() / 4;
  chunk.tets = tet_scratch_;
  tets_emitted_ += chunk.count;
  stats_.tetrahedra = tets_emitted_;
  return true;
}

void MeshStream::drop_repeated_vertex_tets() {
  const size_t count = tet_scratch_.size() / 4;
  size_t kept = 0;
  for (size_t t = 0; t < count; ++t) {
    const uint32_t* v = tet_scratch_.data() + 4 * t;
    if (v[0] == v[1] || v[0] == v[2] || v[0] == v[3] || v[1] == v[2] || v[1] == v[3] || v[2] == v[3]) {
      ++stats_.repeated_vertex;
      continue;
    }
    if (kept != t) {
      std::copy_n(v, 4, tet_scratch_.data() + 4 * kept);
      split_scratch_[kept] = split_scratch_[t];
    }
    ++kept;
  }
  tet_scratch_.resize(4 * kept);
  split_scratch_.resize(kept);
}

void MeshStream::fill_tet_chunk(size_t max_tets) {
  tet_scratch_.reserve(4 * max_tets + 24);
  CellBatch& batch = cells_->batch;
  while (!cells_done_ && tet_scratch_.size() / 4 + 6 <= max_tets) {
    batch.clear();
    size_t want = std::max<size_t>(1, (max_tets - tet_scratch_.size() / 4) / 6);
    if (!reader_->read_cells(batch, want)) {
      cells_done_ = true;
      take_face_tags();
      break;
    }
    stats_.quadratic_cells += batch.reduced;
    if (batch.only_tets && batch.same_cell.empty()) {  // bulk path: one copy
      stats_.cells += batch.size();
      tet_scratch_.insert(tet_scratch_.end(), batch.nodes.begin(), batch.nodes.end());
      split_scratch_.resize(tet_scratch_.size() / 4, 0);
      continue;
    }
    for (size_t c = 0; c < batch.size(); ++c) {
      int type = batch.types[c];
      size_t node_count = batch.offsets[c + 1] - batch.offsets[c];
      std::span<const uint32_t> nodes(batch.nodes.data() + batch.offsets[c], node_count);
      int corners = detail::volume_corner_count(type, static_cast<int>(node_count));
      if (corners <= 0) {
        ++stats_.skipped_cells;
        continue;
      }
      if (!batch.continues(c)) ++stats_.cells;
      if (static_cast<size_t>(corners) < node_count) ++stats_.quadratic_cells;
      const int linear = linear_type(type, corners);
      if (corners == 8) ++stats_.hexahedra;
      if (corners == 6) ++stats_.wedges;
      if (corners == 5) ++stats_.pyramids;
      size_t at = tet_scratch_.size();
      tet_scratch_.resize(at + 4 * 6);
      size_t produced = detail::split_cell(linear, nodes.first(static_cast<size_t>(corners)), tet_scratch_.data() + at);
      tet_scratch_.resize(at + 4 * produced);
      // split products and a decomposed polyhedron's pieces come in either orientation; only
      // native tets count as inverted
      split_scratch_.resize(tet_scratch_.size() / 4, linear == detail::kVtkTetra && !batch.piece(c) ? 0 : 1);
    }
  }
}

void MeshStream::orient_chunk() {
  // Orientation reads four random vertices a tet and dominates reading once parsing is bulk;
  // large chunks are split over two threads.
  const size_t count = tet_scratch_.size() / 4;
  auto orient_range = [this](size_t begin, size_t end, ReadStats& stats) {
    for (size_t t = begin; t < end; ++t) orient(xyz_.data(), tet_scratch_.data() + 4 * t, stats, split_scratch_[t] == 0);
  };
  if (count < kParallelOrientTets) {
    orient_range(0, count, stats_);
    return;
  }
  ReadStats other;
  std::thread helper(orient_range, count / 2, count, std::ref(other));
  orient_range(0, count / 2, stats_);
  helper.join();
  stats_.degenerate += other.degenerate;
  stats_.inverted += other.inverted;
}

TetMesh load_stream(MeshStream& stream) {
  TetMesh mesh;
  const MeshHeader& header = stream.header();
  for (const AttributeInfo& info : header.attributes) {
    mesh.attributes.push_back({info, {}});
    mesh.attributes.back().values.reserve(header.vertex_count * info.components);
  }
  VertexChunk chunk;
  while (stream.next_vertices(chunk)) {
    for (size_t a = 0; a < chunk.attributes.size(); ++a) {
      mesh.attributes[a].values.insert(mesh.attributes[a].values.end(), chunk.attributes[a].begin(), chunk.attributes[a].end());
    }
  }
  for (size_t a = 0; a < mesh.attributes.size(); ++a) mesh.attributes[a].info = header.attributes[a];  // tensors' flags, known now
  std::span<const float> xyz = stream.xyz();
  const size_t n = xyz.size() / 3;
  mesh.x.resize(n);
  mesh.y.resize(n);
  mesh.z.resize(n);
  for (size_t i = 0; i < n; ++i) {
    mesh.x[i] = xyz[3 * i];
    mesh.y[i] = xyz[3 * i + 1];
    mesh.z[i] = xyz[3 * i + 2];
  }
  TetChunk tets;
  while (stream.next_tets(tets)) mesh.tets.insert(mesh.tets.end(), tets.tets.begin(), tets.tets.end());
  mesh.face_tags = stream.face_tags();
  return mesh;
}

TetMesh load_mesh(const std::filesystem::path& path, ReadStats* stats, const ReadLimits& limits) {
  auto stream = MeshStream::open(path, limits);
  TetMesh mesh = load_stream(*stream);
  if (stats) *stats = stream->stats();
  return mesh;
}

}  // namespace tetrascope::storage
