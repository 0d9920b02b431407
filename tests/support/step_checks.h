// What the tests of files holding several time steps share: a step past the last refused with
// a message, and a store made of every step (`preprocess --all-steps`) listed by `info`.
#pragma once

#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include "cli_run.h"
#include "tetrascope/storage/mesh_error.h"
#include "tetrascope/storage/mesh_stream.h"

namespace tetrascope::testing {

// Reading `path` at `step` (past its last) fails with a MeshError whose message holds `expected`.
inline void expect_step_refused(const std::filesystem::path& path, int step, const std::string& expected) {
  storage::ReadLimits limits;
  limits.time_step = step;
  try {
    storage::load_mesh(path, nullptr, limits);
    ADD_FAILURE() << path << ": step " << step << " past the last was read";
  } catch (const storage::MeshError& e) {
    EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
  }
}

// `preprocess FILE -o STORE --all-steps OPTIONS`, then `info STORE --json`: the steps it lists
// (`time_steps.steps`), or an empty array after a failure reported to the test.
inline nlohmann::json all_steps_listed(const std::filesystem::path& file, const std::filesystem::path& store, const std::string& options) {
  std::filesystem::remove_all(store);
  const CliResult r = run_cli("preprocess " + file.string() + " -o " + store.string() + " --all-steps" + options, 300);
  EXPECT_EQ(r.status, 0) << r.out;
  const CliResult info = run_cli("info " + store.string() + " --json", 60);
  EXPECT_EQ(info.status, 0) << info.out;
  if (r.status != 0 || info.status != 0 || info.out.find('{') == std::string::npos) return nlohmann::json::array();
  return nlohmann::json::parse(info.out.substr(info.out.find('{')))["time_steps"]["steps"];
}

}  // namespace tetrascope::testing
