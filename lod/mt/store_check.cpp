#include "tetrascope/lod/mt/store_check.h"

#include <stdexcept>

#include "tetrascope/lod/cut/dag.h"
#include "tetrascope/lod/cut/variants.h"
#include "tetrascope/lod/vertex/vertex_hierarchy.h"
#include "tetrascope/storage/store.h"
#include "tetrascope/storage/store_verify.h"
#include "tetrascope/storage/time_steps.h"

namespace tetrascope::lod {

std::vector<std::string> check_store(const std::filesystem::path& directory) {
  storage::VerifyReport report = storage::verify_store(directory);
  std::vector<std::string> problems = report.problems;
  if (!report.ok && problems.empty()) problems.push_back("the store is damaged");
  if (!problems.empty()) return problems;
  try {
    auto store = storage::Store::open(directory);
    if (auto dag = open_dag(*store)) {
      for (auto& p : verify_dag(*store, *dag)) problems.push_back(p);
      for (auto& p : verify_variants(*store, *dag)) problems.push_back(p);
      for (auto& p : verify_vertex_hierarchy(directory)) problems.push_back(p);
    }
    for (auto& p : storage::verify_time_steps(*store)) problems.push_back(p);
  } catch (const std::exception& e) {
    problems.push_back(e.what());
  }
  return problems;
}

void require_sound_store(const std::filesystem::path& directory) {
  std::vector<std::string> problems = check_store(directory);
  if (problems.empty()) return;
  std::error_code ignored;
  std::filesystem::remove_all(directory, ignored);
  std::string message = directory.string() + ": the written store failed its checks and was removed (please report this with the input file):";
  for (size_t i = 0; i < problems.size() && i < 5; ++i) message += "\n  " + problems[i];
  throw std::runtime_error(message);
}

}  // namespace tetrascope::lod
