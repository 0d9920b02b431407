// The one tetrascope executable; each subcommand lives in the library that owns it and
// this file only parses arguments and maps errors to exit codes.
#include <cstdio>
#include <cstring>
#include <iostream>
#include <string>
#include <vector>

#include "tetrascope/storage/mesh_error.h"
#include "tetrascope/storage/mesh_info.h"

namespace {

constexpr const char* kUsage =
    "usage: tetrascope <command> [options]\n"
    "\n"
    "commands:\n"
    "  info MESH [--json]     counts, attributes with ranges, bounds, quality counters\n"
    "\n"
    "MESH: .vtk (legacy ASCII/BINARY), .vtu, .msh (Gmsh 2.2/4.1), .node/.ele (TetGen), .off\n";

int run_info(const std::vector<std::string>& args) {
  std::string path;
  bool json = false;
  for (const std::string& a : args) {
    if (a == "--json") json = true;
    else if (!a.empty() && a[0] == '-') {
      std::fprintf(stderr, "tetrascope info: unknown option %s\n", a.c_str());
      return 2;
    } else if (path.empty()) path = a;
    else {
      std::fprintf(stderr, "tetrascope info: one mesh at a time\n");
      return 2;
    }
  }
  if (path.empty()) {
    std::fprintf(stderr, "usage: tetrascope info MESH [--json]\n");
    return 2;
  }
  auto summary = tetrascope::storage::summarize_mesh(path);
  if (json) std::cout << tetrascope::storage::summary_json(summary).dump(2) << "\n";
  else std::cout << tetrascope::storage::summary_text(summary);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || !std::strcmp(argv[1], "--help") || !std::strcmp(argv[1], "-h") || !std::strcmp(argv[1], "help")) {
    std::fputs(kUsage, argc < 2 ? stderr : stdout);
    return argc < 2 ? 2 : 0;
  }
  std::string command = argv[1];
  std::vector<std::string> args(argv + 2, argv + argc);
  try {
    if (command == "info") return run_info(args);
    std::fprintf(stderr, "tetrascope: unknown command '%s'\n\n%s", command.c_str(), kUsage);
    return 2;
  } catch (const tetrascope::storage::MeshError& e) {
    std::fprintf(stderr, "tetrascope %s: %s\n", command.c_str(), e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tetrascope %s: error: %s\n", command.c_str(), e.what());
    return 1;
  }
}
