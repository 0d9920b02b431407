// Progress of long commands: a bar on a terminal, JSON lines for the server's job runner
// (`--progress json`: {"stage", "percent", "stage_percent", "elapsed_s", "eta_s"}), or nothing.
#pragma once

#include <chrono>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

namespace tetrascope::storage {

class Progress {
 public:
  enum class Mode { kNone, kBar, kJson };
  // Stages with their share of the whole run (shares are normalised).
  Progress(Mode mode, std::vector<std::pair<std::string, double>> stages, std::FILE* out = stderr);
  void begin(const std::string& stage);
  void update(double stage_fraction);  // throttled
  void finish();
  static Mode mode_from(const std::string& option, bool is_terminal);

 private:
  void emit(bool force);
  Mode mode_;
  std::vector<std::pair<std::string, double>> stages_;
  std::FILE* out_;
  size_t current_ = 0;
  double fraction_ = 0;
  std::chrono::steady_clock::time_point start_, last_;
};

}  // namespace tetrascope::storage
