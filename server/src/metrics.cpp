#include "metrics.h"

#include <cstdio>

namespace tetrascope::server {

void Histogram::observe(double ms) {
  std::lock_guard lock(mutex_);
  size_t b = 0;
  while (b < kBucketsMs.size() && ms > kBucketsMs[b]) ++b;
  ++counts_[b];
  sum_ += ms;
  ++count_;
}

void Histogram::write(std::string& out, const std::string& name, const std::string& help) const {
  std::lock_guard lock(mutex_);
  char line[160];
  out += "# HELP " + name + " " + help + "\n# TYPE " + name + " histogram\n";
  uint64_t cumulative = 0;
  for (size_t b = 0; b < kBucketsMs.size(); ++b) {
    cumulative += counts_[b];
    std::snprintf(line, sizeof line, "%s_bucket{le=\"%g\"} %llu\n", name.c_str(), kBucketsMs[b], static_cast<unsigned long long>(cumulative));
    out += line;
  }
  std::snprintf(line, sizeof line, "%s_bucket{le=\"+Inf\"} %llu\n%s_sum %.3f\n%s_count %llu\n", name.c_str(), static_cast<unsigned long long>(count_), name.c_str(), sum_,
                name.c_str(), static_cast<unsigned long long>(count_));
  out += line;
}

void Metrics::count_error(const std::string& code) {
  std::lock_guard lock(mutex_);
  ++errors_[code];
}

std::map<std::string, uint64_t> Metrics::errors() const {
  std::lock_guard lock(mutex_);
  return errors_;
}

}  // namespace tetrascope::server
