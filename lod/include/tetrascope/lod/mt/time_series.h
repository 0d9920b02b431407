// `tetrascope preprocess` of a time series: the store is built once, from the first step (the
// mesh, its levels, the DAG, the error histograms and vertices.bin as for one mesh), and each
// further step adds its values at every stored vertex to steps.bin (time_steps.h).
//
// A step's values at the input's vertices are the file's (as the reader delivers them: cell
// data averaged at the vertices); at a vertex simplification made (a coarse level's, or one
// vertices.bin's collapses made) they are the step's field interpolated at the vertex's
// position in the input tet that holds it (the one it is least outside of, for a vertex just
// outside the input's boundary), one stencil a vertex found once for every step. Every step
// must have the first step's mesh: the same vertices (coordinates within 1e-6 of the
// bounding-box diagonal), the same tets and the same attributes.
#pragma once

#include <cstdint>
#include <filesystem>
#include <vector>

#include "tetrascope/lod/mt/mt_build.h"
#include "tetrascope/storage/series.h"

namespace tetrascope::lod {

struct SeriesReport {
  uint32_t steps = 0;
  uint64_t steps_bytes = 0;        // steps.bin
  uint64_t interpolated_vertices = 0;  // stored vertices whose values are interpolated
  uint64_t outside_vertices = 0;   // of those, the ones outside every input tet (clamped)
  double seconds = 0;              // reading the further steps and writing steps.bin
};

// Builds the store of `steps` (storage::series_inputs) at `store`, written beside it and
// renamed only when complete. Throws storage::MeshError naming the step for a step whose file
// is missing or unreadable, or whose mesh differs from the first step's;
// std::invalid_argument for options a series cannot take (--variants, several MPI ranks).
SeriesReport preprocess_series(const std::vector<storage::SeriesInput>& steps, const std::filesystem::path& store, const PreprocessOptions& options,
                               storage::Progress* progress = nullptr, PreprocessReport* build = nullptr);

}  // namespace tetrascope::lod
