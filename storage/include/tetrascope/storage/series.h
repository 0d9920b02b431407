// The steps of a time series as `preprocess` is given them: a ParaView data file (.pvd), a
// file series (several files, or a quoted glob pattern), an OpenFOAM case's time folders, or
// the time steps one Exodus II, Gmsh or CGNS file holds.
// Every name is checked here (each step's file must exist and be a mesh file tetrascope
// reads) before any is read; problems raise MeshError naming the file.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "tetrascope/storage/mesh_stream.h"

namespace tetrascope::storage {

struct SeriesInput {
  std::filesystem::path path;  // the step's mesh file (or OpenFOAM time folder)
  double time = 0;             // strictly increasing along the series
  std::string name;            // as a user knows it: the file's or the time folder's name
  // Of a file that holds several time steps: which one (ReadLimits::time_step); -1: the file
  // (or folder) is the step.
  int64_t file_step = -1;
};

// The steps `inputs` name, in time order:
// - one .pvd file: its DataSet entries (timestep, file relative to the .pvd's folder; no
//   absolute paths and no "..", one part a step);
// - one OpenFOAM case with `all_times`: each time folder (a folder named by a number) that
//   holds fields, its number the time;
// - several files, or one pattern with * or ? (expanded here): a file series ordered by the
//   numbers in the names (as ParaView's file series), times 0, 1, 2, ...
// - one Exodus II, Gmsh or CGNS file with `all_times`: each time step it holds (opened with
//   `limits` to list them), its time the file's, named "FILE step K"; the times must increase.
// A single other input is one step: an empty list. Throws MeshError.
std::vector<SeriesInput> series_inputs(const std::vector<std::string>& inputs, bool all_times, const ReadLimits& limits = {});

// "a"-"z" then numbers by value: "step_2" before "step_10".
bool natural_less(const std::string& a, const std::string& b);

}  // namespace tetrascope::storage
