// Writers of every input format the readers accept, for test fixtures and fuzz seeds.
// They are test code: simple, not streaming, and trusted.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "tetrascope/storage/mesh.h"

namespace tetrascope::testing {

// A mesh of any linear VTK cells (tets, hexes, wedges, pyramids, voxels, triangles).
struct CellMesh {
  std::vector<float> x, y, z;
  std::vector<storage::Attribute> attributes;
  std::vector<storage::Attribute> cell_attributes;  // one tuple a cell (VTK CELL_DATA, VTU CellData, Gmsh $ElementData)
  std::vector<uint8_t> types;        // VTK cell types
  std::vector<uint32_t> offsets{0};  // cell c uses connectivity[offsets[c] .. offsets[c+1])
  std::vector<uint32_t> connectivity;
  void add_cell(uint8_t type, std::initializer_list<uint32_t> nodes);
  size_t cell_count() const { return types.size(); }
};

CellMesh from_tets(const storage::TetMesh& mesh);
// One tet and `points` - 4 unused points at the origin: tiny when zlib-compressed, large inflated
// (the decompression bomb of the hostile-input tests).
CellMesh one_tet_and_unused_points(size_t points);

struct VtkOptions {
  bool binary = true;
  bool doubles = false;     // POINTS and arrays as double
  bool field = false;       // point arrays in a FIELD instead of SCALARS/VECTORS
  bool version5 = false;    // 5.1 layout: CELLS with OFFSETS and CONNECTIVITY (vtktypeint64)
};
void write_vtk_legacy(const std::filesystem::path& path, const CellMesh& mesh, const VtkOptions& options = {});

enum class VtuEncoding { kAscii, kInlineBase64, kAppendedRaw, kAppendedBase64 };
struct VtuOptions {
  VtuEncoding encoding = VtuEncoding::kAppendedRaw;
  bool zlib = false;
  bool header_uint64 = true;
  bool doubles = false;
  bool separate_header = false;  // base64: encode the size header and the data separately
  size_t block_size = 4096;      // zlib block size
};
void write_vtu(const std::filesystem::path& path, const CellMesh& mesh, const VtuOptions& options = {});

struct GmshOptions {
  bool version4 = false;  // 4.1, else 2.2
  bool binary = false;
  uint32_t first_tag = 1;  // node tags start here (and step by tag_step)
  uint32_t tag_step = 1;
  // Per cell its physical tag (0: none), written as the first element tag (2.2) or as the
  // physical tag of a surface entity of its own per run of cells ($Entities, 4.1); empty: 1
  // for every cell in 2.2, none in 4.1.
  std::vector<int32_t> physical{};
  std::vector<std::pair<int32_t, std::string>> surface_names{};  // $PhysicalNames of dimension 2
};
void write_gmsh(const std::filesystem::path& path, const CellMesh& mesh, const GmshOptions& options = {});
// A Gmsh $NodeData or $ElementData section (`section`) of field `name` at time step number
// `step_number` and time `time`: `components` values a row, the rows by node or element tag;
// `binary`: the rows as a binary file holds them (a 32-bit tag, then doubles), the header in text.
std::string gmsh_data_section(const std::string& section, const std::string& name, int step_number, double time, uint32_t components,
                              const std::vector<std::pair<size_t, std::vector<double>>>& rows, bool binary = false);

// The cube [0,1]^3 as 2x2x2 hexahedra (27 nodes) with tagged boundary faces, for Gmsh files:
// x = 0 "inlet" (physical 1, 4 quads), x = 1 "outlet" (2, 4 quads), y = 1 and z = 0 "walls"
// (3, 8 quads), z = 1 physical 7 without a name (8 triangles, cut as the hexahedra are), y = 0
// untagged (4 quads), and the inner plane x = 0.5 "mid plane" (4, 4 quads, no boundary).
struct TaggedCube {
  CellMesh mesh;
  GmshOptions gmsh;
};
TaggedCube tagged_cube();

// Writes BASE.node and BASE.ele (tets only), 1-based, with scalar attributes named in a comment.
void write_tetgen(const std::filesystem::path& base, const CellMesh& mesh);
// HAVS-style OFF with the first scalar attribute as the 4th column (tets only).
void write_off(const std::filesystem::path& path, const CellMesh& mesh);

std::string read_file(const std::filesystem::path& path);
// Loads the mesh at `path` whole: "" when it reads, else the MeshError's message (any other
// exception passes through).
std::string mesh_read_error(const std::filesystem::path& path);
void write_file(const std::filesystem::path& path, const std::string& bytes);

}  // namespace tetrascope::testing
