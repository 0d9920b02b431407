#include "tetrascope/storage/progress.h"

#include <algorithm>

namespace tetrascope::storage {

Progress::Progress(Mode mode, std::vector<std::pair<std::string, double>> stages, std::FILE* out)
    : mode_(mode), stages_(std::move(stages)), out_(out), start_(std::chrono::steady_clock::now()), last_(start_) {
  double total = 0;
  for (auto& s : stages_) total += s.second;
  for (auto& s : stages_) s.second = total > 0 ? s.second / total : 0;
}

Progress::Mode Progress::mode_from(const std::string& option, bool is_terminal) {
  if (option == "json") return Mode::kJson;
  if (option == "none") return Mode::kNone;
  return is_terminal ? Mode::kBar : Mode::kNone;
}

void Progress::begin(const std::string& stage) {
  for (size_t i = 0; i < stages_.size(); ++i) {
    if (stages_[i].first == stage) current_ = i;
  }
  fraction_ = 0;
  emit(true);
}

void Progress::update(double stage_fraction) {
  fraction_ = std::clamp(stage_fraction, 0.0, 1.0);
  emit(false);
}

void Progress::finish() {
  current_ = stages_.empty() ? 0 : stages_.size() - 1;
  fraction_ = 1;
  emit(true);
  if (mode_ == Mode::kBar) std::fputc('\n', out_);
}

void Progress::emit(bool force) {
  if (mode_ == Mode::kNone || stages_.empty()) return;
  auto now = std::chrono::steady_clock::now();
  if (!force && now - last_ < std::chrono::milliseconds(mode_ == Mode::kJson ? 500 : 100)) return;
  last_ = now;
  double done = 0;
  for (size_t i = 0; i < current_; ++i) done += stages_[i].second;
  done += stages_[current_].second * fraction_;
  double elapsed = std::chrono::duration<double>(now - start_).count();
  double eta = done > 0.02 ? elapsed * (1 - done) / done : -1;
  const std::string& stage = stages_[current_].first;
  if (mode_ == Mode::kJson) {
    std::fprintf(out_, "{\"stage\": \"%s\", \"percent\": %.1f, \"stage_percent\": %.1f, \"elapsed_s\": %.2f, \"eta_s\": %.1f}\n",
                 stage.c_str(), 100 * done, 100 * fraction_, elapsed, eta);
  } else {
    int filled = static_cast<int>(done * 30);
    std::fprintf(out_, "\r%-16s [%-30s] %5.1f%%  ", stage.c_str(), std::string(static_cast<size_t>(filled), '#').c_str(), 100 * done);
    if (eta >= 0) std::fprintf(out_, "ETA %4.0fs ", eta);
  }
  std::fflush(out_);
}

}  // namespace tetrascope::storage
