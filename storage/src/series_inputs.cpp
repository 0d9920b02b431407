#include "tetrascope/storage/series.h"

#include <glob.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <regex>
#include <set>

#include "tetrascope/storage/mesh_error.h"
#include "tetrascope/storage/mesh_stream.h"

namespace tetrascope::storage {
namespace fs = std::filesystem;
namespace {

constexpr uint64_t kMaxPvdBytes = 64ull << 20;
constexpr size_t kMaxSteps = 100000;

// The value of attribute `name` in an XML start tag's text, or "" (no entity other than the
// five XML ones is decoded).
std::string xml_attribute(const std::string& tag, const std::string& name) {
  const std::regex pattern("\\s" + name + "\\s*=\\s*(\"([^\"]*)\"|'([^']*)')");
  std::smatch m;
  if (!std::regex_search(tag, m, pattern)) return {};
  std::string v = m[2].matched ? m[2].str() : m[3].str();
  const std::pair<const char*, const char*> entities[] = {{"&quot;", "\""}, {"&apos;", "'"}, {"&lt;", "<"}, {"&gt;", ">"}, {"&amp;", "&"}};
  for (const auto& [from, to] : entities)
    for (size_t at = v.find(from); at != std::string::npos; at = v.find(from, at + 1)) v.replace(at, std::strlen(from), to);
  return v;
}

void check_step_file(const fs::path& path, const std::string& where) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw MeshError(where + path.string() + ": no such file (a step of the series is missing)");
  format_from_path(path);  // a format tetrascope reads
}

std::vector<SeriesInput> read_pvd(const fs::path& pvd) {
  std::ifstream in(pvd, std::ios::binary);
  if (!in) throw MeshError(pvd.string() + ": cannot open");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (text.size() > kMaxPvdBytes) throw MeshError(pvd.string() + ": larger than " + std::to_string(kMaxPvdBytes) + " bytes");
  if (text.find("<VTKFile") == std::string::npos || text.find("Collection") == std::string::npos) throw MeshError(pvd.string() + ": not a ParaView data file (no VTKFile Collection)");
  std::vector<SeriesInput> out;
  std::set<double> times;
  for (size_t at = text.find("<DataSet"); at != std::string::npos; at = text.find("<DataSet", at + 1)) {
    const size_t end = text.find('>', at);
    if (end == std::string::npos) throw MeshError(pvd.string() + ": byte " + std::to_string(at) + ": unterminated DataSet tag");
    const std::string tag = text.substr(at, end - at);
    const std::string where = pvd.string() + ": DataSet " + std::to_string(out.size()) + ": ";
    const std::string file = xml_attribute(tag, "file"), step = xml_attribute(tag, "timestep"), part = xml_attribute(tag, "part");
    if (file.empty()) throw MeshError(where + "no file attribute");
    if (!part.empty() && part != "0") throw MeshError(where + "part " + part + ": a step of several parts is not read (one part a step)");
    const fs::path relative(file);
    if (relative.is_absolute() || std::any_of(relative.begin(), relative.end(), [](const fs::path& p) { return p == ".."; }))
      throw MeshError(where + "'" + file + "': a .pvd names files in its own folder or below it");
    char* stop = nullptr;
    const double t = step.empty() ? double(out.size()) : std::strtod(step.c_str(), &stop);
    if (!step.empty() && (*stop != '\0' || !std::isfinite(t))) throw MeshError(where + "timestep '" + step + "' is not a number");
    if (!times.insert(t).second) throw MeshError(where + "timestep " + step + " appears twice");
    out.push_back({pvd.parent_path() / relative, t, file});
    if (out.size() > kMaxSteps) throw MeshError(pvd.string() + ": more than " + std::to_string(kMaxSteps) + " steps");
  }
  if (out.empty()) throw MeshError(pvd.string() + ": no DataSet entries");
  std::sort(out.begin(), out.end(), [](const SeriesInput& a, const SeriesInput& b) { return a.time < b.time; });
  return out;
}

std::vector<SeriesInput> openfoam_times(const fs::path& input) {
  std::error_code ec;
  const fs::path folder = fs::is_directory(input, ec) ? input : input.parent_path();
  std::vector<SeriesInput> out;
  for (const auto& entry : fs::directory_iterator(folder, ec)) {
    if (!is_openfoam_time_folder(entry.path())) continue;
    bool fields = false;  // a time folder without a field (a restart's leftovers) is no step
    for (const auto& file : fs::directory_iterator(entry.path(), ec)) fields = fields || file.is_regular_file(ec);
    if (fields) out.push_back({entry.path(), std::strtod(entry.path().filename().c_str(), nullptr), entry.path().filename().string()});
  }
  std::sort(out.begin(), out.end(), [](const SeriesInput& a, const SeriesInput& b) { return a.time < b.time; });
  if (out.size() < 2) throw MeshError(input.string() + ": " + std::to_string(out.size()) + " time folder" + (out.size() == 1 ? "" : "s") + " with fields: a series needs two or more");
  for (size_t i = 1; i < out.size(); ++i)
    if (!(out[i].time > out[i - 1].time)) throw MeshError(folder.string() + ": time folders " + out[i - 1].name + " and " + out[i].name + " have the same time");
  return out;
}

// The time steps one file holds (Exodus II, Gmsh, CGNS), each a step of the series.
std::vector<SeriesInput> file_steps(const fs::path& file, const ReadLimits& limits) {
  const MeshFormat format = format_from_path(file);
  if (format != MeshFormat::kExodus && format != MeshFormat::kGmsh && format != MeshFormat::kCgns) {
    throw MeshError(file.string() + ": --all-steps reads the time steps of an Exodus II, Gmsh or CGNS file or an OpenFOAM case's time folders; give the steps of " +
                    format_name(format) + " files as files (a list, a pattern or a .pvd)");
  }
  const std::vector<double> times = MeshStream::open(file, limits)->header().step_times;
  if (times.size() < 2) throw MeshError(file.string() + ": holds fewer than two time steps: --all-steps needs two or more");
  if (times.size() > kMaxSteps) throw MeshError(file.string() + ": more than " + std::to_string(kMaxSteps) + " steps");
  std::vector<SeriesInput> out;
  for (size_t k = 0; k < times.size(); ++k) {
    const std::string name = file.filename().string() + " step " + std::to_string(k);
    if (!std::isfinite(times[k])) throw MeshError(file.string() + ": time step " + std::to_string(k) + ": its time is not finite");
    if (k > 0 && !(times[k] > times[k - 1]))
      throw MeshError(file.string() + ": time step " + std::to_string(k) + " (t = " + std::to_string(times[k]) + ") is not after step " + std::to_string(k - 1) + " (t = " + std::to_string(times[k - 1]) +
                      "): a series' times increase");
    out.push_back({file, times[k], name, static_cast<int64_t>(k)});
  }
  return out;
}

std::vector<std::string> expand_pattern(const std::string& pattern) {
  glob_t g{};
  const int r = ::glob(pattern.c_str(), GLOB_NOSORT, nullptr, &g);
  std::vector<std::string> out;
  if (r == 0)
    for (size_t i = 0; i < g.gl_pathc; ++i) out.emplace_back(g.gl_pathv[i]);
  ::globfree(&g);
  if (out.empty()) throw MeshError(pattern + ": no file matches the pattern");
  return out;
}

}  // namespace

bool natural_less(const std::string& a, const std::string& b) {
  size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    if (std::isdigit(static_cast<unsigned char>(a[i])) && std::isdigit(static_cast<unsigned char>(b[j]))) {
      size_t ie = i, je = j;
      while (ie < a.size() && std::isdigit(static_cast<unsigned char>(a[ie]))) ++ie;
      while (je < b.size() && std::isdigit(static_cast<unsigned char>(b[je]))) ++je;
      std::string x = a.substr(i, ie - i), y = b.substr(j, je - j);
      x.erase(0, std::min(x.find_first_not_of('0'), x.size()));
      y.erase(0, std::min(y.find_first_not_of('0'), y.size()));
      if (x.size() != y.size()) return x.size() < y.size();
      if (x != y) return x < y;
      i = ie;
      j = je;
      continue;
    }
    if (a[i] != b[j]) return a[i] < b[j];
    ++i;
    ++j;
  }
  return a.size() - i < b.size() - j;
}

std::vector<SeriesInput> series_inputs(const std::vector<std::string>& inputs, bool all_times, const ReadLimits& limits) {
  if (inputs.empty()) throw MeshError("no input");
  std::vector<SeriesInput> out;
  if (inputs.size() == 1) {
    const fs::path p(inputs[0]);
    std::string ext = p.extension().string();
    for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    if (ext == ".pvd") out = read_pvd(p);
    else if (all_times && format_from_path(p) == MeshFormat::kOpenFoam) out = openfoam_times(p);
    else if (all_times) out = file_steps(p, limits);
    else if (inputs[0].find_first_of("*?") == std::string::npos) return {};
  }
  if (out.empty()) {
    std::vector<std::string> files;
    for (const std::string& input : inputs) {
      if (input.find_first_of("*?") != std::string::npos) {
        for (auto& f : expand_pattern(input)) files.push_back(std::move(f));
      } else {
        files.push_back(input);
      }
    }
    std::sort(files.begin(), files.end(), natural_less);
    if (std::adjacent_find(files.begin(), files.end()) != files.end()) throw MeshError(*std::adjacent_find(files.begin(), files.end()) + ": named twice in the series");
    if (files.size() > kMaxSteps) throw MeshError("more than " + std::to_string(kMaxSteps) + " steps");
    for (size_t i = 0; i < files.size(); ++i) out.push_back({files[i], double(i), fs::path(files[i]).filename().string()});
  }
  if (out.size() < 2) throw MeshError(inputs[0] + ": a series of one step; give two or more");
  for (size_t i = 0; i < out.size(); ++i) check_step_file(out[i].path, "step " + std::to_string(i) + ": ");
  return out;
}

}  // namespace tetrascope::storage
