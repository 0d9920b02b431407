// Stores built once per test program and checks shared by the multi-triangulation's tests
// (mt_build_test.cpp, cut_test.cpp, dag_test.cpp).
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <set>
#include <string>

#include "tetrascope/lod/cut/cut.h"
#include "tetrascope/lod/mt/mt_build.h"

namespace tetrascope::testing {

struct Built {
  std::filesystem::path store;
  lod::PreprocessReport report;
};

// The store of `name` ("sample" or a file of ../shared/data) with 2000-tet segments and a
// 3000-tet base (and `variants` variants a segment, variants.h), built on first use.
const Built& built(const std::string& name, uint32_t variants = 0);
// The same mesh as a binary segment hierarchy (preprocess --model binary, §6.2), 2000-tet
// segments, a 3000-tet base, boundaries simplified between new segments whose ratio R is at
// least `dependency_ratio` (negative: never).
const Built& built_binary(const std::string& name, double dependency_ratio = 1.0);

using Tet = std::array<uint32_t, 4>;

// The tets of a cut as sorted global vertex ids.
std::multiset<Tet> tets_by_global_id(const lod::CutMesh& m);

// Conformity of an assembled cut: every face used once (boundary) or twice, the boundary
// closed (each boundary edge in exactly two boundary triangles), no inverted tet, and the
// summed tet volume equal to the volume the boundary encloses (overlaps or gaps break it).
void expect_conforming(const lod::CutMesh& m, const std::string& what);
// The same checks on a mesh alone; returns its boundary faces.
size_t expect_conforming(const storage::TetMesh& mesh, const std::string& what);

}  // namespace tetrascope::testing
