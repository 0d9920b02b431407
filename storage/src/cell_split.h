#pragma once
#include <cstdint>
#include <span>

namespace tetrascope::storage::detail {

// Splits a linear cell (VTK type tetra, voxel, hexahedron, wedge or pyramid, corner vertices
// in VTK order, global ids) into tets written to `out` (4 ids each, at most 6 tets); returns
// the tet count. Tets are not oriented.
size_t split_cell(int vtk_type, std::span<const uint32_t> corners, uint32_t* out);

}  // namespace tetrascope::storage::detail
