#pragma once
#include <filesystem>
#include <string>

#include "tetrascope/storage/sanitizer.h"

namespace tetrascope::testing {

// An AddressSanitizer build: tests that take minutes there (and seconds in release) skip
// themselves in it and say so; the release run covers them.
constexpr bool kSanitized = storage::kAddressSanitizer;

std::filesystem::path source_dir();
std::filesystem::path sample_mesh();  // data/samples/disk_out_ref.vtk
// ../shared/data next to the checkout; empty when it is not there (tests then skip).
std::filesystem::path shared_data();
std::filesystem::path tetrascope_binary();
// A fresh empty directory for one test, under TMPDIR/tetrascope-PID/. It is removed when the
// test ends without failing (or, made outside a test, at the end of a run where all passed).
std::filesystem::path scratch_dir(const std::string& name);
// The same, for something built once and kept across tests (a cache in a static): removed at
// the end of a run where every test passed.
std::filesystem::path run_scratch_dir(const std::string& name);

}  // namespace tetrascope::testing
