// Runs the tetrascope executable as a user does: exit status and everything it printed.
#pragma once

#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <string>

#include "test_paths.h"

namespace tetrascope::testing {

struct CliResult {
  int status;
  std::string out;  // stdout and stderr
};

inline CliResult run_cli(const std::string& args) {
  const std::string command = tetrascope_binary().string() + " " + args + " 2>&1";
  FILE* pipe = popen(command.c_str(), "r");
  std::string out;
  std::array<char, 4096> buffer;
  size_t n;
  while ((n = fread(buffer.data(), 1, buffer.size(), pipe)) > 0) out.append(buffer.data(), n);
  const int status = pclose(pipe);
  return {WEXITSTATUS(status), out};
}

}  // namespace tetrascope::testing
