// Command-line arguments of the subcommands: positionals and --name value / --flag options,
// and the checked conversions of option values (untrusted: each bad value is an
// std::invalid_argument naming the option).
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "tetrascope/view/camera.h"
#include "tetrascope/view/transfer_function.h"
#include "tetrascope/storage/progress.h"

namespace tetrascope::apps {

class Args {
 public:
  // `flags` take no value, `valued` take one; "-o" is "--output". Throws on an unknown option.
  Args(const std::vector<std::string>& args, const std::vector<std::string>& flags, const std::vector<std::string>& valued);
  const std::vector<std::string>& positionals() const { return positionals_; }
  bool has(const std::string& name) const { return values_.count(name) != 0; }
  std::string get(const std::string& name, const std::string& fallback = "") const;
  // A whole number 0..2^32-1, or `fallback` when the option is absent.
  uint32_t number(const std::string& name, uint32_t fallback) const;
  // A finite number (the option must be present).
  double real(const std::string& name) const;
  // A number above 0, or `fallback` when the option is absent.
  double positive(const std::string& name, double fallback) const;

 private:
  std::vector<std::string> positionals_;
  std::map<std::string, std::string> values_;
};

// --progress bar|json|none (bar only on a terminal).
storage::Progress::Mode progress_mode(const Args& args);
// "v1,v2,...": finite numbers.
std::vector<double> number_list(const std::string& option, const std::string& list);
// A transfer-function file (`--tf FILE`), checked by protocol::transfer_function_from_json.
view::TransferFunction read_tf(const std::string& path);
// `--component`: "magnitude" (view::kMagnitude), "x", "y" or "z" (0, 1, 2).
int parse_component(const std::string& text);
struct ImageSize {
  uint32_t width = 0, height = 0;
};
// "WxH", each side in min_side..max_side.
ImageSize parse_size(const std::string& option, const std::string& text, uint32_t min_side, uint32_t max_side);
// The token from --token or $TETRASCOPE_TOKEN.
std::string token_option(const Args& args);

}  // namespace tetrascope::apps
