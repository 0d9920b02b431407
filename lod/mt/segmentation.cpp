// Out-of-core segmentation, dissertation §6.1.1-6.1.3, written into the store format of
// storage/store_format.h.
//
// Pass 1 streams the vertices (kept in memory) and partitions them (octree + METIS).
// Segments are numbered by ascending vertex count. Pass 2 streams the tets, gives each to the
// lowest segment among its vertices and spills it to that segment's blocks in a temporary
// file. Pass 3 reads each segment back, pairs its faces locally and collects the unpaired
// ones; a global sort pairs those across segments (segment borders) and leaves the mesh
// boundary. Pass 4 writes the segments in streaming order: owned vertices first, then shared
// copies; border tets first (§6.2.3); opposites inside the segment, links across it.
#include "tetrascope/lod/mt/segmentation.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <future>
#include <limits>
#include <numeric>
#include <optional>
#include <atomic>
#include <stdexcept>
#include <thread>

#include "tetrascope/lod/mt/octree_partition.h"
#include "tetrascope/lod/mt/streaming_order.h"
#include "tetrascope/storage/mesh_stream.h"
#include "tetrascope/core/parallel_for.h"
#include "tetrascope/storage/sha256.h"
#include "tetrascope/storage/store_format.h"
#include "tetrascope/storage/store_writer.h"
#include "tetrascope/storage/tensor.h"
#include "tetrascope/core/tet_topology.h"

namespace tetrascope::lod {
namespace {

using storage::store::BorderLink;

// Tets of every segment, spilled in blocks to one temporary file (one descriptor however many
// segments there are).
class TetSpill {
 public:
  static constexpr uint32_t kBlockTets = 1024;
  TetSpill(const std::filesystem::path& path, uint32_t segments) : path_(path), buffers_(segments), blocks_(segments), counts_(segments, 0) {
    file_ = std::fopen(path.c_str(), "w+b");
    if (!file_) throw std::runtime_error(path.string() + ": cannot create spill file");
  }
  ~TetSpill() {
    if (file_) std::fclose(file_);
    std::error_code ignored;
    std::filesystem::remove(path_, ignored);
  }
  void add(uint32_t segment, const uint32_t* tet) {
    auto& buffer = buffers_[segment];
    buffer.insert(buffer.end(), tet, tet + 4);
    ++counts_[segment];
    if (buffer.size() == 4 * kBlockTets) flush(segment);
  }
  void flush_all() {
    for (uint32_t s = 0; s < buffers_.size(); ++s) {
      if (!buffers_[s].empty()) flush(s);
      std::vector<uint32_t>().swap(buffers_[s]);
    }
    std::fflush(file_);
  }
  uint64_t count(uint32_t segment) const { return counts_[segment]; }
  // All tets of a segment, in the order they were added.
  void read(uint32_t segment, std::vector<uint32_t>& out) const {
    out.resize(4 * counts_[segment]);
    size_t at = 0;
    for (auto [offset, tets] : blocks_[segment]) {
      if (::pread(fileno(file_), out.data() + at, 16 * size_t{tets}, static_cast<off_t>(offset)) != static_cast<ssize_t>(16 * size_t{tets})) {
        throw std::runtime_error(path_.string() + ": spill read failed");
      }
      at += 4 * size_t{tets};
    }
  }

 private:
  void flush(uint32_t segment) {
    auto& buffer = buffers_[segment];
    blocks_[segment].push_back({written_, static_cast<uint32_t>(buffer.size() / 4)});
    if (std::fwrite(buffer.data(), 4, buffer.size(), file_) != buffer.size()) throw std::runtime_error(path_.string() + ": spill write failed (disk full?)");
    written_ += 4 * buffer.size();
    buffer.clear();
  }
  std::filesystem::path path_;
  std::FILE* file_ = nullptr;
  std::vector<std::vector<uint32_t>> buffers_;
  std::vector<std::vector<std::pair<uint64_t, uint32_t>>> blocks_;
  std::vector<uint64_t> counts_;
  uint64_t written_ = 0;
};

struct Link {  // a border face of one segment (raw numbering) and its partner
  uint32_t face, segment, remote_face;
};

// A temporary file, closed and removed when this goes.
struct FileCloser {
  FileCloser(const std::filesystem::path& p) : fd(::open(p.c_str(), O_RDWR | O_CREAT | O_TRUNC | O_CLOEXEC, 0600)), path(p) {}
  FileCloser(const FileCloser&) = delete;
  int fd;
  std::filesystem::path path;
  ~FileCloser() {
    if (fd >= 0) ::close(fd);
    std::error_code ignored;
    std::filesystem::remove(path, ignored);
  }
};

// One run of segment_mesh: the passes share the vertices, the partition and the spill files.
struct Segmentation {
  Segmentation(const std::filesystem::path& mesh, const std::filesystem::path& store, const SegmentationOptions& o, storage::Progress* p)
      : mesh_path(mesh), store_path(store), options(o), progress(p) {}

  void report_progress(const char* stage, double fraction) const {
    if (!progress) return;
    if (fraction == 0) progress->begin(stage);
    else progress->update(fraction);
  }

  // Pass 1: the vertices (kept in memory) and every attribute's range.
  void read_vertices() {
    report_progress("read vertices", 0);
    stream = storage::MeshStream::open(mesh_path, options.read_limits);
    header = stream->header();
    vertex_count = header.vertex_count;
    if (vertex_count == 0) throw std::runtime_error(mesh_path.string() + ": the mesh has no vertices");
    floats_per_vertex = 0;
    for (const auto& a : header.attributes) floats_per_vertex += a.components;
    attributes.resize(header.attributes.size());
    for (size_t a = 0; a < attributes.size(); ++a) attributes[a].reserve(vertex_count * header.attributes[a].components);
    ranges.assign(header.attributes.size(), std::array<double, 2>{std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()});
    component_ranges.assign(header.attributes.size(), {});
    for (size_t a = 0; a < attributes.size(); ++a)
      if (header.attributes[a].components > 1) component_ranges[a].assign(header.attributes[a].components, ranges[a]);
    storage::VertexChunk chunk;
    while (stream->next_vertices(chunk)) {
      for (size_t a = 0; a < attributes.size(); ++a) {
        const uint32_t c = header.attributes[a].components;
        attributes[a].insert(attributes[a].end(), chunk.attributes[a].begin(), chunk.attributes[a].end());
        for (size_t i = 0; i < chunk.count; ++i) {
          double value = 0;
          for (uint32_t k = 0; k < c; ++k) value += double(chunk.attributes[a][i * c + k]) * chunk.attributes[a][i * c + k];
          for (uint32_t k = 0; k < component_ranges[a].size(); ++k) {
            const double x = chunk.attributes[a][i * c + k];
            if (std::isfinite(x)) component_ranges[a][k] = {std::min(component_ranges[a][k][0], x), std::max(component_ranges[a][k][1], x)};
          }
          value = c == 1 ? double(chunk.attributes[a][i]) : std::sqrt(value);
          if (!std::isfinite(value)) continue;
          ranges[a][0] = std::min(ranges[a][0], value);
          ranges[a][1] = std::max(ranges[a][1], value);
        }
      }
      report_progress("read vertices", double(chunk.first + chunk.count) / double(vertex_count));
    }
    header = stream->header();  // tensors' flags are known once every vertex was read
    xyz = stream->xyz();
  }

  // Octree + METIS over the vertices (the step preprocess shares); owned vertices per segment.
  void partition() {
    report_progress("partition", 0);
    estimated_tets = std::max<uint64_t>(header.cell_count, 1);
    const uint32_t parts = options.segments ? options.segments
                                            : static_cast<uint32_t>(std::max<uint64_t>(1, (estimated_tets + options.segment_tets / 2) / options.segment_tets));
    // A vertex's share of the tets (incident tets / 4), from a first pass over the tets, lets
    // METIS balance tets as well as vertices: near the mesh boundary a vertex has fewer tets.
    std::vector<float> tets_per_vertex(vertex_count, 0.0f);
    {
      auto count_stream = storage::MeshStream::open(mesh_path, options.read_limits);
      storage::TetChunk counted;
      while (count_stream->next_tets(counted)) {
        for (uint32_t v : counted.tets) tets_per_vertex[v] += 0.25f;
        report_progress("partition", std::min(0.9, 0.9 * double(counted.first + counted.count) / double(estimated_tets)));
      }
    }
    SegmentPartition partition = partition_segments(xyz, parts, options.leaf_vertices, options.seed, tets_per_vertex);
    std::vector<float>().swap(tets_per_vertex);
    segment_count = partition.segments;
    segment_of_vertex = std::move(partition.segment_of_vertex);
    leaf_count = partition.leaves;
    contiguous = partition.contiguous;
    leaf_vertices = partition.leaf_vertices;
    // owned vertices of every segment, ascending global id
    owned_begin.assign(segment_count + 1, 0);
    for (uint32_t s : segment_of_vertex) ++owned_begin[s + 1];
    for (uint32_t s = 0; s < segment_count; ++s) owned_begin[s + 1] += owned_begin[s];
    owned.resize(vertex_count);
    {
      std::vector<uint64_t> fill(owned_begin.begin(), owned_begin.end() - 1);
      for (uint64_t v = 0; v < vertex_count; ++v) owned[fill[segment_of_vertex[v]]++] = static_cast<uint32_t>(v);
    }
  }

  // Pass 2: every tet to the lowest segment among its vertices, spilled to disk.
  void assign_tets() {
    report_progress("assign tets", 0);
    spill_file.emplace(writer->temp_directory() / "tets.spill", segment_count);
    TetSpill& spill = *spill_file;
    storage::TetChunk tets;
    while (stream->next_tets(tets)) {
      for (size_t t = 0; t < tets.count; ++t) {
        const uint32_t* tet = tets.tets.data() + 4 * t;
        const uint32_t s0 = segment_of_vertex[tet[0]], s1 = segment_of_vertex[tet[1]], s2 = segment_of_vertex[tet[2]], s3 = segment_of_vertex[tet[3]];
        const uint32_t s = segment_of_tet(segment_of_vertex, tet);
        spill.add(s, tet);
        for (uint32_t o : {s0, s1, s2, s3}) {
          if (o != s) pairs.push_back(uint64_t{s} << 32 | o);
        }
      }
      if (pairs.size() > (1u << 22)) {
        std::sort(pairs.begin(), pairs.end());
        pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
      }
      report_progress("assign tets", estimated_tets ? std::min(1.0, double(tets.first + tets.count) / double(estimated_tets)) : 0);
    }
    spill.flush_all();
    read_stats = stream->stats();
    tet_count = 0;
    for (uint32_t s = 0; s < segment_count; ++s) {
      tet_count += spill.count(s);
      if (spill.count(s) > storage::store::kMaxSegmentTets) throw std::runtime_error("a segment got more than 2^30 tets; use more segments");
    }
    if (tet_count == 0) throw std::runtime_error(mesh_path.string() + ": the mesh has no tetrahedra");
  }

  // Pass 3: faces paired inside every segment (kept on disk), then across segments (links).
  void match_faces() {
    TetSpill& spill = *spill_file;
    report_progress("match faces", 0);
    workers = std::max(1u, std::min(2u, std::thread::hardware_concurrency()));
    scratch.resize(workers);  // one per worker: parallel_for hands out worker indices
    for (auto& sc : scratch) sc.local_of.assign(vertex_count, kNoOppositeFace);
    std::vector<std::vector<OpenFace>> unpaired_by_worker(workers);
    // the in-segment pairing is kept on disk for pass 4 (16 bytes a tet, not in memory)
    partner_offset.assign(segment_count + 1, 0);
    for (uint32_t s = 0; s < segment_count; ++s) partner_offset[s + 1] = partner_offset[s] + 16 * spill.count(s);
    partner_path = writer->temp_directory() / "partners.spill";
    partners.emplace(partner_path);
    if (partners->fd < 0) throw std::runtime_error(partner_path.string() + ": cannot create spill file");
    bounds.resize(segment_count);
    std::atomic<uint32_t> matched{0};
    parallel_for(segment_count, workers, [&](size_t item, unsigned w) {
      const uint32_t s = static_cast<uint32_t>(item);
      std::vector<uint32_t> segment_tets, partner;
      spill.read(s, segment_tets);
      pair_faces(segment_tets, scratch[w], partner);
      transfer(true, s, partner);
      for (uint32_t face = 0; face < partner.size(); ++face) {
        if (partner[face] != kNoOppositeFace) continue;
        unpaired_by_worker[w].push_back({face_key(tet_face(segment_tets, face / 4, int(face % 4))), s, face});
      }
      std::array<float, 6>& b = bounds[s];
      b = {std::numeric_limits<float>::max(), std::numeric_limits<float>::max(), std::numeric_limits<float>::max(),
           std::numeric_limits<float>::lowest(), std::numeric_limits<float>::lowest(), std::numeric_limits<float>::lowest()};
      auto extend = [&](uint32_t v) {
        for (int k = 0; k < 3; ++k) {
          b[k] = std::min(b[k], xyz[3 * size_t{v} + k]);
          b[3 + k] = std::max(b[3 + k], xyz[3 * size_t{v} + k]);
        }
      };
      for (uint32_t v : segment_tets) extend(v);
      for (uint64_t i = owned_begin[s]; i < owned_begin[s + 1]; ++i) extend(owned[i]);
      if (w == 0) report_progress("match faces", 0.7 * (matched.load() + 1) / segment_count);
      ++matched;
    });
    std::vector<OpenFace> unpaired;
    for (auto& list : unpaired_by_worker) {
      unpaired.insert(unpaired.end(), list.begin(), list.end());
      std::vector<OpenFace>().swap(list);
    }
    links.resize(segment_count);
    border_tets.resize(segment_count);
    pair_open_faces(unpaired, [&](const OpenFace& a, const OpenFace& b) {
      if (a.segment == b.segment) return;
      links[a.segment].push_back({a.face, b.segment, b.face});
      links[b.segment].push_back({b.face, a.segment, a.face});
      border_tets[a.segment].push_back(a.face / 4);
      border_tets[b.segment].push_back(b.face / 4);
      pairs.push_back(uint64_t{a.segment} << 32 | b.segment);
    });
    std::vector<OpenFace>().swap(unpaired);
    for (auto& list : border_tets) {
      std::sort(list.begin(), list.end());
      list.erase(std::unique(list.begin(), list.end()), list.end());
    }
    std::sort(pairs.begin(), pairs.end());
    pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
    neighbours.resize(segment_count);
    for (uint64_t p : pairs) {
      uint32_t a = static_cast<uint32_t>(p >> 32), b = static_cast<uint32_t>(p);
      neighbours[a].push_back(b);
      neighbours[b].push_back(a);
    }
    std::vector<uint64_t>().swap(pairs);
    for (auto& list : neighbours) {
      std::sort(list.begin(), list.end());
      list.erase(std::unique(list.begin(), list.end()), list.end());
    }
    order = streaming_order(neighbours, bounds);
  }

  // The in-segment pairing of segment s to (write) or from the partner spill file.
  void transfer(bool write, uint32_t s, std::vector<uint32_t>& partner) const {
    const size_t bytes = 4 * partner.size();
    ssize_t done = write ? ::pwrite(partners->fd, partner.data(), bytes, static_cast<off_t>(partner_offset[s]))
                         : ::pread(partners->fd, partner.data(), bytes, static_cast<off_t>(partner_offset[s]));
    if (done != static_cast<ssize_t>(bytes)) throw std::runtime_error(partner_path.string() + ": spill " + (write ? "write failed (disk full?)" : "read failed"));
  }

  // raw tet -> position after moving border tets to the front (stable)
  uint32_t final_tet(uint32_t s, uint32_t raw) const {
    const auto& list = border_tets[s];
    auto it = std::lower_bound(list.begin(), list.end(), raw);
    uint32_t rank = static_cast<uint32_t>(it - list.begin());
    if (it != list.end() && *it == raw) return rank;
    return static_cast<uint32_t>(list.size()) + raw - rank;
  }

  // Builds segment s into `data` with worker w's scratch.
  void build_segment(uint32_t s, unsigned w, storage::SegmentData& data) {
    const TetSpill& spill = *spill_file;
    FacePairingScratch& sc = scratch[w];
    std::vector<uint32_t> segment_tets, partner;
    spill.read(s, segment_tets);
    const uint32_t raw_count = static_cast<uint32_t>(segment_tets.size() / 4);
    partner.resize(segment_tets.size());
    transfer(false, s, partner);
    data = storage::SegmentData();
    data.id = s;
    // vertices: owned first, then shared copies, each ascending by global id
    std::vector<uint32_t>& local_of = sc.local_of;
    for (uint64_t i = owned_begin[s]; i < owned_begin[s + 1]; ++i) data.global_ids.push_back(owned[i]);
    data.owned_vertex_count = static_cast<uint32_t>(data.global_ids.size());
    std::vector<uint32_t> shared;
    for (uint32_t v : segment_tets) {
      if (segment_of_vertex[v] != s) shared.push_back(v);
    }
    std::sort(shared.begin(), shared.end());
    shared.erase(std::unique(shared.begin(), shared.end()), shared.end());
    data.global_ids.insert(data.global_ids.end(), shared.begin(), shared.end());
    const size_t nv = data.global_ids.size();
    for (size_t l = 0; l < nv; ++l) local_of[data.global_ids[l]] = static_cast<uint32_t>(l);
    data.x.resize(nv);
    data.y.resize(nv);
    data.z.resize(nv);
    data.attributes.resize(nv * floats_per_vertex);
    size_t attribute_base = 0;
    for (size_t a = 0; a < attributes.size(); ++a) {
      const uint32_t c = header.attributes[a].components;
      for (size_t l = 0; l < nv; ++l) {
        for (uint32_t k = 0; k < c; ++k) data.attributes[attribute_base + l * c + k] = attributes[a][size_t{data.global_ids[l]} * c + k];
      }
      attribute_base += nv * c;
    }
    for (size_t l = 0; l < nv; ++l) {
      const uint32_t g = data.global_ids[l];
      data.x[l] = xyz[3 * size_t{g}];
      data.y[l] = xyz[3 * size_t{g} + 1];
      data.z[l] = xyz[3 * size_t{g} + 2];
    }
    // tets: border tets first
    data.boundary_tet_count = static_cast<uint32_t>(border_tets[s].size());
    data.tets.resize(segment_tets.size());
    for (uint32_t raw = 0; raw < raw_count; ++raw) {
      uint32_t t = final_tet(s, raw);
      for (int k = 0; k < 4; ++k) data.tets[4 * size_t{t} + k] = local_of[segment_tets[4 * size_t{raw} + k]];
    }
    for (uint32_t g : data.global_ids) local_of[g] = kNoOppositeFace;
    // opposites: inside the segment from the local pairing, borders from the links
    data.opposites.assign(segment_tets.size(), storage::store::kMeshBoundary);
    for (uint32_t face = 0; face < partner.size(); ++face) {
      if (partner[face] == kNoOppositeFace) continue;
      data.opposites[final_tet(s, face / 4) * 4 + face % 4] = final_tet(s, partner[face] / 4) * 4 + partner[face] % 4;
    }
    for (const Link& link : links[s]) {
      uint32_t face = final_tet(s, link.face / 4) * 4 + link.face % 4;
      data.opposites[face] = storage::store::kSegmentBorder;
      data.links.push_back({face, link.segment, final_tet(link.segment, link.remote_face / 4) * 4 + link.remote_face % 4});
    }
    std::sort(data.links.begin(), data.links.end(), [](const BorderLink& a, const BorderLink& b) { return a.face < b.face; });
    std::copy(bounds[s].begin(), bounds[s].end(), data.bounds);
  }

  // Pass 4: the segments, built two at a time, written in streaming order.
  void write_segments() {
    report_progress("write segments", 0);
    report.min_vertices = report.min_tets = std::numeric_limits<uint32_t>::max();
    // build `workers` segments at once, write them in streaming order
    std::vector<storage::SegmentData> built(workers);
    for (size_t step = 0; step < order.order.size(); step += workers) {
      const size_t batch = std::min<size_t>(workers, order.order.size() - step);
      parallel_for(batch, static_cast<unsigned>(batch), [&](size_t i, unsigned w) { build_segment(order.order[step + i], w, built[i]); });
      for (size_t i = 0; i < batch; ++i) {
        const storage::SegmentData& data = built[i];
        writer->add_segment(data);
        const uint32_t nv = static_cast<uint32_t>(data.global_ids.size()), nt = static_cast<uint32_t>(data.tets.size() / 4);
        report.min_vertices = std::min(report.min_vertices, nv);
        report.max_vertices = std::max(report.max_vertices, nv);
        report.min_tets = std::min(report.min_tets, nt);
        report.max_tets = std::max(report.max_tets, nt);
        report.avg_vertices += double(nv) / segment_count;
      }
      report_progress("write segments", double(step + batch) / segment_count);
    }
  }

  // manifest.json, and the store renamed into place.
  void finish() {
    nlohmann::json manifest;
    manifest["format"] = "tetrascope-store";
    manifest["version"] = storage::store::kFormatVersion;
    std::error_code ec;
    manifest["source"] = {{"file", std::filesystem::absolute(mesh_path).string()}, {"format", storage::format_name(header.format)},
                          {"bytes", std::filesystem::file_size(hashed, ec)}, {"sha256", sha256->get()}};
    manifest["counts"] = {{"vertices", vertex_count}, {"tetrahedra", tet_count}, {"segments", segment_count},
                          {"degenerate_tetrahedra", read_stats.degenerate}, {"reoriented_tetrahedra", read_stats.inverted}};
    nlohmann::json attribute_list = nlohmann::json::array();
    for (size_t a = 0; a < header.attributes.size(); ++a) {
      double lo = std::isfinite(ranges[a][0]) ? ranges[a][0] : 0, hi = std::isfinite(ranges[a][1]) ? ranges[a][1] : 0;
      attribute_list.push_back({{"name", header.attributes[a].name}, {"components", header.attributes[a].components}, {"min", lo}, {"max", hi},
                                {"range_of", header.attributes[a].components == 1 ? "value" : "magnitude"},
                                // normalised = (value - offset) * scale maps the range to [0, 1]
                                {"normalisation", {{"offset", lo}, {"scale", hi > lo ? 1.0 / (hi - lo) : 1.0}}}});
      if (!component_ranges[a].empty()) {
        nlohmann::json list = nlohmann::json::array();
        for (const auto& r : component_ranges[a]) list.push_back(std::isfinite(r[0]) ? nlohmann::json{r[0], r[1]} : nlohmann::json{0, 0});
        attribute_list.back()["component_ranges"] = list;
      }
      storage::add_attribute_kind_json(attribute_list.back(), header.attributes[a]);
    }
    manifest["attributes"] = attribute_list;
    std::array<double, 6> all{std::numeric_limits<double>::max(), std::numeric_limits<double>::max(), std::numeric_limits<double>::max(),
                              std::numeric_limits<double>::lowest(), std::numeric_limits<double>::lowest(), std::numeric_limits<double>::lowest()};
    for (const auto& b : bounds) {
      for (int k = 0; k < 3; ++k) {
        all[k] = std::min<double>(all[k], b[k]);
        all[3 + k] = std::max<double>(all[3 + k], b[3 + k]);
      }
    }
    manifest["bounds"] = {{"min", {all[0], all[1], all[2]}}, {"max", {all[3], all[4], all[5]}}};
    manifest["build"] = {{"leaf_vertices", leaf_vertices}, {"segment_tets", options.segment_tets}, {"segments_requested", options.segments},
                         {"seed", options.seed}, {"octree_leaves", leaf_count}, {"metis_contiguous", contiguous}};
    manifest["stream"] = {{"tags", order.tags}, {"max_workload_segments", order.max_workload}};
    report.vertices = vertex_count;
    report.tets = tet_count;
    report.segments = segment_count;
    report.leaves = leaf_count;
    report.avg_tets = double(tet_count) / segment_count;
    report.max_workload = order.max_workload;
    report.contiguous = contiguous;
    report.store_bytes = writer->bytes_written();
    manifest["segmentation"] = report.to_json();
    manifest["segmentation"].erase("seconds");
    manifest["segmentation"].erase("store_bytes");
    report_progress("write segments", 1);
    spill_file.reset();  // removes the spill files before the directory is renamed
    partners.reset();
    writer->finish(neighbours, manifest);
  }

  const std::filesystem::path mesh_path, store_path;
  const SegmentationOptions& options;
  storage::Progress* progress;
  std::optional<storage::FileHasher> sha256;  // of the source, computed while we work
  std::filesystem::path hashed;     // the file hashed
  // pass 1
  std::unique_ptr<storage::MeshStream> stream;
  storage::MeshHeader header;
  uint64_t vertex_count = 0;
  uint32_t floats_per_vertex = 0;
  std::vector<std::vector<float>> attributes;
  std::vector<std::array<double, 2>> ranges;
  std::vector<std::vector<std::array<double, 2>>> component_ranges;  // per attribute, each vector component's
  std::span<const float> xyz;
  // partition
  uint64_t estimated_tets = 0;
  uint32_t segment_count = 0, leaf_count = 0, leaf_vertices = 0;
  bool contiguous = false;
  std::vector<uint32_t> segment_of_vertex;
  std::vector<uint64_t> owned_begin;
  std::vector<uint32_t> owned;  // owned vertices of every segment, ascending global id
  std::optional<storage::StoreWriter> writer;
  // pass 2
  std::optional<TetSpill> spill_file;
  std::vector<uint64_t> pairs;  // (segment << 32 | neighbour) for vertex-sharing segments
  storage::ReadStats read_stats;
  uint64_t tet_count = 0;
  // pass 3
  unsigned workers = 1;
  std::vector<FacePairingScratch> scratch;  // one per worker: parallel_for hands out worker indices
  std::vector<uint64_t> partner_offset;
  std::filesystem::path partner_path;
  std::optional<FileCloser> partners;
  std::vector<std::array<float, 6>> bounds;
  std::vector<std::vector<Link>> links;
  std::vector<std::vector<uint32_t>> border_tets;  // raw tet ids with a border face, ascending
  std::vector<std::vector<uint32_t>> neighbours;
  StreamOrder order;
  // pass 4
  SegmentationReport report;
};

}  // namespace

nlohmann::json SegmentationReport::to_json() const {
  return {{"vertices", vertices}, {"tetrahedra", tets}, {"segments", segments}, {"octree_leaves", leaves},
          {"vertices_per_segment", {{"min", min_vertices}, {"avg", avg_vertices}, {"max", max_vertices}}},
          {"tets_per_segment", {{"min", min_tets}, {"avg", avg_tets}, {"max", max_tets}}},
          {"max_tets_over_avg", avg_tets > 0 ? max_tets / avg_tets : 0.0},
          {"max_workload_segments", max_workload},
          {"max_workload_fraction", segments ? double(max_workload) / segments : 0.0},
          {"metis_contiguous", contiguous}, {"store_bytes", store_bytes}, {"seconds", seconds}};
}

SegmentationReport segment_mesh(const std::filesystem::path& mesh_path, const std::filesystem::path& store_path,
                                const SegmentationOptions& options, storage::Progress* progress) {
  using clock = std::chrono::steady_clock;
  const auto start = clock::now();
  if (options.leaf_vertices != 0 && (options.leaf_vertices < kMinLeafVertices || options.leaf_vertices > kMaxLeafVertices)) {
    throw std::invalid_argument("--leaf-vertices must be " + std::to_string(kMinLeafVertices) + " to " + std::to_string(kMaxLeafVertices));
  }
  if (options.segments == 0 && options.segment_tets < kMinSegmentTets) {
    throw std::invalid_argument("--segment-tets must be at least " + std::to_string(kMinSegmentTets));
  }
  if (options.segments > storage::store::kMaxSegments) throw std::invalid_argument("--segments is too large");
  Segmentation run(mesh_path, store_path, options, progress);
  // fingerprint the source while we work
  run.hashed = mesh_path;
  if (storage::format_from_path(mesh_path) == storage::MeshFormat::kTetgen) run.hashed.replace_extension(".ele");
  run.sha256.emplace(run.hashed);  // checks the file is regular first; cancelled if reading fails
  run.read_vertices();
  run.partition();
  run.writer.emplace(store_path, options.replace, run.vertex_count, run.segment_count, run.floats_per_vertex);
  run.assign_tets();
  run.match_faces();
  run.write_segments();
  run.finish();
  run.report.seconds = std::chrono::duration<double>(clock::now() - start).count();
  if (progress) progress->finish();
  return run.report;
}

}  // namespace tetrascope::lod
