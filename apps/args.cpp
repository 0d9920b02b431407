#include "args.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <stdexcept>

#include "tetrascope/protocol/transfer_function.h"
#include "tetrascope/storage/parse_number.h"

namespace tetrascope::apps {

Args::Args(const std::vector<std::string>& args, const std::vector<std::string>& flags, const std::vector<std::string>& valued) {
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (a.size() > 1 && a[0] == '-') {
      const std::string name = a == "-o" ? "--output" : a;
      if (std::find(flags.begin(), flags.end(), name) != flags.end()) {
        values_.insert_or_assign(name, std::string(1, '1'));
      } else if (std::find(valued.begin(), valued.end(), name) != valued.end()) {
        if (i + 1 >= args.size()) throw std::invalid_argument(name + " needs a value");
        values_[name] = args[++i];
      } else {
        throw std::invalid_argument("unknown option " + a);
      }
    } else {
      positionals_.push_back(a);
    }
  }
}

std::string Args::get(const std::string& name, const std::string& fallback) const {
  auto it = values_.find(name);
  return it == values_.end() ? fallback : it->second;
}

uint32_t Args::number(const std::string& name, uint32_t fallback) const {
  if (!has(name)) return fallback;
  const std::string& text = values_.at(name);
  uint64_t v = 0;
  if (text.empty() || text[0] == '+' || !parse_number(text, v) || v > 0xFFFFFFFFull) throw std::invalid_argument(name + " expects a whole number, got '" + text + "'");
  return static_cast<uint32_t>(v);
}

double Args::real(const std::string& name) const {
  const std::string text = get(name);
  double v = 0;
  if (!parse_number(text, v) || !std::isfinite(v)) throw std::invalid_argument(name + " expects a number, got '" + text + "'");
  return v;
}

double Args::positive(const std::string& name, double fallback) const {
  if (!has(name)) return fallback;
  const double v = real(name);
  if (!(v > 0)) throw std::invalid_argument(name + " must be above 0");
  return v;
}

storage::Progress::Mode progress_mode(const Args& args) {
  const std::string option = args.get("--progress", "bar");
  if (option != "bar" && option != "json" && option != "none") throw std::invalid_argument("--progress expects bar, json or none");
  return storage::Progress::mode_from(option, option == "json" || ::isatty(STDERR_FILENO));
}

std::vector<double> number_list(const std::string& option, const std::string& list) {
  std::vector<double> out;
  for (size_t at = 0; at <= list.size();) {
    size_t comma = list.find(',', at);
    if (comma == std::string::npos) comma = list.size();
    const std::string item = list.substr(at, comma - at);
    double v = 0;
    if (!parse_number(item, v) || !std::isfinite(v)) throw std::invalid_argument(option + " expects numbers separated by commas, got '" + item + "'");
    out.push_back(v);
    at = comma + 1;
  }
  return out;
}

view::TransferFunction read_tf(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::invalid_argument("--tf: cannot read " + path);
  nlohmann::json j = nlohmann::json::parse(in, nullptr, false);
  if (j.is_discarded()) throw std::invalid_argument("--tf: " + path + " is not JSON");
  return protocol::transfer_function_from_json(j);
}

int parse_component(const std::string& text) {
  if (text == "magnitude") return view::kMagnitude;
  for (size_t k = 0; k < view::kComponentNames.size(); ++k)
    if (text == view::kComponentNames[k]) return static_cast<int>(k);
  throw std::invalid_argument("--component expects magnitude, x, y or z, got '" + text + "'");
}

ImageSize parse_size(const std::string& option, const std::string& text, uint32_t min_side, uint32_t max_side) {
  const size_t x = text.find('x');
  uint64_t w = 0, h = 0;
  if (x == std::string::npos || !parse_number(std::string_view(text).substr(0, x), w) || !parse_number(std::string_view(text).substr(x + 1), h) || w < min_side ||
      h < min_side || w > max_side || h > max_side)
    throw std::invalid_argument(option + " expects WxH, each " + std::to_string(min_side) + ".." + std::to_string(max_side));
  return {static_cast<uint32_t>(w), static_cast<uint32_t>(h)};
}

std::string token_option(const Args& args) {
  const char* environment = std::getenv("TETRASCOPE_TOKEN");
  return args.get("--token", environment ? environment : "");
}

}  // namespace tetrascope::apps
