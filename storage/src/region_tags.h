// Boundary face tags from a VTK region-id array: the triangles and quads of an unstructured
// grid (beside its volume cells) tagged by the integer value a cell array gives them, one tag
// per distinct id. Shared by the legacy (.vtk) and XML (.vtu) readers.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "format_reader.h"

namespace tetrascope::storage::detail {

// The names a region-id cell array goes by (compared case-insensitively): Gmsh's export,
// ParaView's connectivity and threshold filters, meshio, FEniCS/DOLFINx and common solvers.
inline constexpr std::string_view kRegionArrayNames[] = {"gmsh:physical", "RegionId", "region", "BoundaryId", "boundary_id", "zone", "CellEntityIds"};

// The index of the region-id array among the cell arrays `names` (with `components`): the first
// in the file's order that bears one of kRegionArrayNames and has one component; none when
// no array does.
std::optional<size_t> find_region_array(const std::vector<std::string>& names, const std::vector<uint32_t>& components);

// The triangles and quads met among the cells, by their number in the file, until the region
// array is read once the cells are over.
class SurfaceRegions {
 public:
  // Notes the cell just pushed onto `batch` (number `cell` in the file) when it is a triangle
  // or a quad; other cells are left out.
  void note(const CellBatch& batch, uint64_t cell);
  void clear() {
    cells_.clear();
    corners_.clear();
  }
  bool empty() const { return cells_.empty(); }
  // The tags: `values` is the region array (one value a cell, from the first cell), `integral`
  // whether its type is an integer type (else each value must be a whole number), `array` its
  // name for errors. A tag per distinct id, "region ID", in increasing order of the ids; a quad
  // becomes two triangles by the diagonal through its vertex of smallest id, as hexahedra are
  // split.
  FaceTags resolve(ValueStream& values, bool integral, const std::string& array) const;

 private:
  std::vector<uint64_t> cells_;                  // ascending
  std::vector<std::array<uint32_t, 4>> corners_;  // a triangle's fourth corner is kNoCorner
  static constexpr uint32_t kNoCorner = UINT32_MAX;
};

}  // namespace tetrascope::storage::detail
