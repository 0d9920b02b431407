// Streaming mesh ingest: vertices first, then tetrahedra, in chunks.
//
// Memory stays proportional to the vertex count (the stream keeps the coordinates, 12 bytes
// a vertex, to orient tets) plus one chunk, whatever the number of cells. Input is untrusted:
// every count, offset and index is checked before use, and problems raise MeshError naming
// the file and the line or byte offset.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "tetrascope/storage/mesh.h"
#include "tetrascope/storage/mesh_error.h"

namespace tetrascope::storage {

enum class MeshFormat { kVtkLegacy, kVtu, kGmsh, kTetgen, kOff, kExodus, kOpenFoam, kCgns };

// "vtk", "vtu", "msh", "tetgen", "off", "exodus", "openfoam", "cgns".
const char* format_name(MeshFormat format);

// The format from the file name (.vtk .vtu .msh .node .ele .off, Exodus II .exo .e .ex2 .exii
// .g .gen, an OpenFOAM case folder or a .foam/.OpenFOAM file in it, CGNS .cgns .adf); throws
// MeshError otherwise.
MeshFormat format_from_path(const std::filesystem::path& path);
// A time folder of an OpenFOAM case (a folder named by a number beside constant/polyMesh):
// read as the case with that time's fields.
bool is_openfoam_time_folder(const std::filesystem::path& path);
// The file a store's manifest fingerprints (sha256, bytes) for an input: TetGen's .ele, an
// OpenFOAM case folder's or time folder's constant/polyMesh/points, else the file itself.
std::filesystem::path fingerprinted_file(const std::filesystem::path& path);

struct MeshHeader {
  MeshFormat format = MeshFormat::kVtkLegacy;
  std::string description;  // e.g. "VTK legacy 3.0 BINARY", "Gmsh 4.1 ascii"
  uint64_t vertex_count = 0;
  uint64_t cell_count = 0;  // all cells in the file, before splitting or skipping
  // What the stream delivers per vertex: the file's point data, then its cell data averaged
  // at the vertices (the last cell_attributes.size() entries).
  std::vector<AttributeInfo> attributes;
  // The file's cell data, as read (a name that a point array also has gets "_cells" in
  // `attributes`). A cell array becomes vertex data by the volume-weighted mean over the
  // volume cells around each vertex: Σ V_c·f_c / Σ V_c (surface, line and point cells do not
  // count; a vertex whose cells all have zero volume takes their plain mean, one in no volume
  // cell 0).
  std::vector<AttributeInfo> cell_attributes;
  // The times of the time steps a file holds (Exodus II, Gmsh, CGNS), in the file's order;
  // empty for a file of one step or none. ReadLimits::time_step chooses the one read.
  std::vector<double> step_times;
  size_t point_attribute_count() const { return attributes.size() - cell_attributes.size(); }
};

// A run of consecutive vertices; spans are valid until the next call on the stream.
struct VertexChunk {
  uint64_t first = 0;
  size_t count = 0;
  std::span<const float> x, y, z;
  std::vector<std::span<const float>> attributes;  // count * components each
};

// A run of tetrahedra: 4 * count global vertex indices, positively oriented.
struct TetChunk {
  uint64_t first = 0;
  size_t count = 0;
  std::span<const uint32_t> tets;
};

// What one input may cost beyond its own bytes. Compressed VTU arrays can inflate about
// 1000:1, so a 240 KB file could otherwise declare 20 million points (and a 1.5 GB read).
struct ReadLimits {
  static constexpr double kDefaultMaxInflateRatio = 100;
  // Inflated bytes always allowed, whatever the ratio: small files may compress very well.
  static constexpr uint64_t kInflateAllowanceBytes = uint64_t{64} << 20;
  // The arrays a file declares compressed may inflate to at most this many times the file's
  // size, plus kInflateAllowanceBytes (`--max-inflate-ratio`).
  double max_inflate_ratio = kDefaultMaxInflateRatio;
  // Which of a file's time steps is read (0-based, MeshHeader::step_times' order), for a
  // format that holds several in one file (Exodus II, Gmsh, CGNS): -1 the last, as a mesh is
  // read alone; a step of a time series (`preprocess --all-steps`) otherwise, whose values are
  // then checked step by step (a step past the last is refused).
  int64_t time_step = -1;
  uint64_t max_inflated_bytes(uint64_t file_bytes) const;
};

namespace detail {
class FormatReader;
class TensorExpansion;
}

class MeshStream {
 public:
  static constexpr size_t kDefaultChunk = 1 << 16;

  // Opens and indexes the file (reads headers, checks sizes); no vertex is read yet.
  // The path must name a regular file (a FIFO, device or directory is refused without blocking).
  static std::unique_ptr<MeshStream> open(const std::filesystem::path& path, const ReadLimits& limits = {});
  // The same over bytes in memory (fuzzing, tests). TetGen takes `.node` then `.ele` bytes.
  static std::unique_ptr<MeshStream> open_memory(MeshFormat format, std::string name,
                                                 std::span<const char> bytes,
                                                 std::span<const char> second_bytes = {},
                                                 const ReadLimits& limits = {});
  ~MeshStream();
  MeshStream(const MeshStream&) = delete;
  MeshStream& operator=(const MeshStream&) = delete;

  // Tensor attributes appear as 6 symmetric components followed by their derived scalars
  // (tensor.h); their positive_semidefinite flags are set once the last vertex was read.
  const MeshHeader& header() const { return public_header_; }

  // Next run of at most `max_vertices` vertices; false when all were delivered.
  bool next_vertices(VertexChunk& chunk, size_t max_vertices = kDefaultChunk);
  // Next run of tets; call after all vertices were read. False at the end.
  bool next_tets(TetChunk& chunk, size_t max_tets = kDefaultChunk);

  // Coordinates of all vertices read so far, interleaved x0 y0 z0 x1 ... (kept to orient
  // tets); the caller may borrow them instead of keeping a copy.
  std::span<const float> xyz() const { return xyz_; }

  const ReadStats& stats() const { return stats_; }

  // The input's tagged boundary faces (Gmsh physical surfaces, OpenFOAM patches; vertex ids as
  // delivered), complete once next_tets returned false; empty for a format or file without.
  const FaceTags& face_tags() const { return face_tags_; }
  // The most tags a mesh may carry: one region each in a list a user reads.
  static constexpr size_t kMaxFaceTags = 4096;

 private:
  void take_face_tags();
  explicit MeshStream(std::unique_ptr<detail::FormatReader> reader);
  void fill_tet_chunk(size_t max_tets);
  void drop_repeated_vertex_tets();
  void orient_chunk();
  // Reads every vertex and, in one pass over the cells, averages the cell data at them; the
  // cells are then rewound for next_tets. Memory: the vertices' values and one double a
  // value component and vertex while it runs.
  void convert_cell_data();
  void accumulate_cell_data(std::vector<double>& sums, std::vector<double>& weights, std::vector<uint8_t>& marks, bool plain);
  static constexpr size_t kParallelOrientTets = 16384;

  std::unique_ptr<detail::FormatReader> reader_;
  MeshHeader header_;         // as the reader gives it (tensors of 9 or 6 components)
  MeshHeader public_header_;  // as delivered
  std::unique_ptr<detail::TensorExpansion> tensors_;
  ReadStats stats_;
  std::vector<float> xyz_;
  uint64_t vertices_read_ = 0;
  uint64_t tets_emitted_ = 0;
  std::vector<float> soa_scratch_;
  std::vector<std::vector<float>> attribute_scratch_;
  std::vector<std::vector<float>> held_attributes_;  // every vertex's values, when the file has cell data
  bool cell_data_converted_ = false;
  std::vector<uint32_t> tet_scratch_;
  std::vector<uint8_t> split_scratch_;  // per tet in the chunk: 1 when it came from a split cell
  struct CellScratch;
  std::unique_ptr<CellScratch> cells_;
  bool cells_done_ = false;
  bool repeated_vertex_warned_ = false;
  FaceTags face_tags_;
};

// Reads a whole (small) mesh into memory. `stats` may be null.
TetMesh load_mesh(const std::filesystem::path& path, ReadStats* stats = nullptr, const ReadLimits& limits = {});
TetMesh load_stream(MeshStream& stream);

}  // namespace tetrascope::storage
