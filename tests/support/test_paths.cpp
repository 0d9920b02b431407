#include "test_paths.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <mutex>
#include <vector>

namespace tetrascope::testing {
namespace fs = std::filesystem;

namespace {

fs::path process_scratch_root() { return fs::path(::testing::TempDir()) / ("tetrascope-" + std::to_string(::getpid())); }

// Scratch folders remove themselves: a test's when it ends without failing, the process's own
// folder at the end of the run when every test passed. A failed test keeps its folder for
// inspection. (Test runs used to leave thousands of /tmp/tetrascope-* folders behind.)
class ScratchCleaner : public ::testing::EmptyTestEventListener {
 public:
  static ScratchCleaner& instance() {
    static ScratchCleaner* cleaner = [] {
      auto* c = new ScratchCleaner;
      ::testing::UnitTest::GetInstance()->listeners().Append(c);  // gtest owns it from here
      return c;
    }();
    return *cleaner;
  }
  // A folder made inside a test goes with the test; one made outside (a suite's set-up) lives
  // until the end of the run.
  void made(const fs::path& folder, bool for_the_run) {
    if (for_the_run || ::testing::UnitTest::GetInstance()->current_test_info() == nullptr) return;
    std::lock_guard lock(mutex_);
    made_.push_back(folder);
  }
  void OnTestEnd(const ::testing::TestInfo& info) override {
    std::vector<fs::path> folders;
    {
      std::lock_guard lock(mutex_);
      folders.swap(made_);
    }
    if (info.result() != nullptr && (info.result()->Failed() || info.result()->HasFatalFailure())) return;
    std::error_code ec;
    for (const auto& folder : folders) fs::remove_all(folder, ec);
  }
  void OnTestProgramEnd(const ::testing::UnitTest& unit_test) override {
    std::error_code ec;
    if (unit_test.Passed()) fs::remove_all(process_scratch_root(), ec);
    else fs::remove(process_scratch_root(), ec);  // only when empty: failed tests' folders stay
  }

 private:
  std::mutex mutex_;
  std::vector<fs::path> made_;
};

// Registers the cleaner before RUN_ALL_TESTS, in every test binary that links this file.
const bool kCleanerRegistered = (ScratchCleaner::instance(), true);

}  // namespace

fs::path source_dir() { return TETRA_SOURCE_DIR; }
fs::path sample_mesh() { return source_dir() / "data/samples/disk_out_ref.vtk"; }
fs::path shared_data() {
  fs::path p = TETRA_SHARED_DATA;
  return fs::exists(p / "README.md") ? p : fs::path();
}
fs::path tetrascope_binary() { return TETRA_BINARY; }
namespace {
fs::path make_scratch_dir(const std::string& name, bool for_the_run) {
  (void)kCleanerRegistered;
  fs::path p = process_scratch_root() / name;
  fs::remove_all(p);
  fs::create_directories(p);
  ScratchCleaner::instance().made(p, for_the_run);
  return p;
}
}  // namespace

fs::path scratch_dir(const std::string& name) { return make_scratch_dir(name, false); }
fs::path run_scratch_dir(const std::string& name) { return make_scratch_dir(name, true); }

}  // namespace tetrascope::testing
