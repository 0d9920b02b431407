// Runs the tetrascope executable as a user does: exit status and everything it printed.
#pragma once

#include <sys/wait.h>

#include <array>
#include <chrono>
#include <cstdio>
#include <string>

#include "test_paths.h"

namespace tetrascope::testing {

struct CliResult {
  int status;
  std::string out;      // stdout and stderr
  double seconds = 0;   // wall time of the run
};

// `timeout_seconds` > 0 runs it under timeout(1), so a hang fails the test instead of the suite.
inline CliResult run_cli(const std::string& args, int timeout_seconds = 0) {
  const auto start = std::chrono::steady_clock::now();
  const std::string command = (timeout_seconds > 0 ? "timeout " + std::to_string(timeout_seconds) + " " : std::string()) +
                              tetrascope_binary().string() + " " + args + " 2>&1";
  FILE* pipe = popen(command.c_str(), "r");
  std::string out;
  std::array<char, 4096> buffer;
  size_t n;
  while ((n = fread(buffer.data(), 1, buffer.size(), pipe)) > 0) out.append(buffer.data(), n);
  const int status = pclose(pipe);
  return {WEXITSTATUS(status), out, std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()};
}

}  // namespace tetrascope::testing
