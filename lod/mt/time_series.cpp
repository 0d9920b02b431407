// preprocess of a time series (time_series.h): the store of the first step, then steps.bin.
#include "tetrascope/lod/mt/time_series.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "tet_locator.h"
#include "tetrascope/lod/vertex/vertex_hierarchy.h"
#include "tetrascope/storage/mesh_error.h"
#include "tetrascope/storage/mesh_stream.h"
#include "tetrascope/storage/store.h"
#include "tetrascope/storage/store_writer.h"
#include "tetrascope/storage/time_steps.h"

namespace tetrascope::lod {
namespace {

namespace fs = std::filesystem;

// A step's mesh as the stream delivers it, compacted as the build compacts it (points no tet
// uses dropped): coordinates, values (rows of `floats`), and a fingerprint of the tets.
struct StepData {
  uint64_t file_vertices = 0, tets = 0;
  uint32_t tets_crc = 0;
  std::vector<float> xyz, values;
  std::vector<storage::AttributeInfo> attributes;
};

// The limits a step is read with: a step of a file holding several names its time step.
storage::ReadLimits step_limits(const storage::SeriesInput& step, storage::ReadLimits limits) {
  limits.time_step = step.file_step;
  return limits;
}

StepData read_step(const storage::SeriesInput& step, uint32_t floats, const storage::ReadLimits& limits) {
  auto stream = storage::MeshStream::open(step.path, step_limits(step, limits));
  StepData d;
  d.attributes = stream->header().attributes;
  uint32_t delivered = 0;
  for (const auto& a : d.attributes) delivered += a.components;
  const bool keep = delivered == floats;  // else the attributes differ: reported by the caller
  storage::VertexChunk chunk;
  while (stream->next_vertices(chunk)) {
    for (size_t i = 0; i < chunk.count; ++i) {
      d.xyz.insert(d.xyz.end(), {chunk.x[i], chunk.y[i], chunk.z[i]});
      if (!keep) continue;
      for (size_t a = 0; a < chunk.attributes.size(); ++a) {
        const uint32_t c = d.attributes[a].components;
        d.values.insert(d.values.end(), chunk.attributes[a].begin() + static_cast<std::ptrdiff_t>(i * c), chunk.attributes[a].begin() + static_cast<std::ptrdiff_t>((i + 1) * c));
      }
    }
  }
  d.file_vertices = d.xyz.size() / 3;
  std::vector<uint8_t> used(d.file_vertices, 0);
  storage::TetChunk tets;
  while (stream->next_tets(tets)) {
    d.tets += tets.count;
    d.tets_crc = storage::crc32_of(tets.tets.data(), tets.tets.size_bytes(), d.tets_crc);
    for (uint32_t v : tets.tets) used[v] = 1;
  }
  // compact in order, as the build does
  uint64_t kept = 0;
  for (uint64_t v = 0; v < d.file_vertices; ++v) {
    if (!used[v]) continue;
    if (kept != v) {
      std::copy_n(d.xyz.begin() + static_cast<std::ptrdiff_t>(3 * v), 3, d.xyz.begin() + static_cast<std::ptrdiff_t>(3 * kept));
      if (keep) std::copy_n(d.values.begin() + static_cast<std::ptrdiff_t>(v * floats), floats, d.values.begin() + static_cast<std::ptrdiff_t>(kept * floats));
    }
    ++kept;
  }
  d.xyz.resize(3 * kept);
  if (keep) d.values.resize(kept * floats);
  return d;
}

// A vertex simplification made: where its values come from in the input mesh.
struct Stencil {
  uint32_t ids[4] = {0, 0, 0, 0};
  float w[4] = {1, 0, 0, 0};
};

// The vertices to interpolate: vertices.bin's collapsed vertices (C), then the store's
// vertices V..N-1, 3 floats each.
std::vector<float> interpolated_positions(const storage::Store& store, const storage::StepLayout& layout, const VertexHierarchy* hierarchy) {
  std::vector<float> out((layout.collapses + layout.store_vertices - layout.input_vertices) * 3, 0.0f);
  if (hierarchy)
    std::copy(hierarchy->positions.begin() + static_cast<std::ptrdiff_t>(3 * layout.input_vertices), hierarchy->positions.end(), out.begin());
  const auto& levels = store.manifest().json.at("multiresolution").at("levels");
  const uint32_t first_coarse = levels.size() > 1 ? levels[1].at("first_segment").get<uint32_t>() : store.segment_count();
  for (uint32_t s = first_coarse; s < store.segment_count(); ++s) {
    const auto mapped = store.map_segment(s);
    const storage::SegmentView& v = mapped->view();
    for (uint32_t l = 0; l < v.vertex_count; ++l) {
      const uint64_t g = v.global_ids[l];
      if (g < layout.input_vertices) continue;
      const uint64_t p = layout.collapses + g - layout.input_vertices;
      out[3 * p] = v.x[l];
      out[3 * p + 1] = v.y[l];
      out[3 * p + 2] = v.z[l];
    }
  }
  return out;
}

// The input segment's tets as a mesh of their own (local ids), and their global ids.
storage::TetMesh segment_mesh(const storage::SegmentView& v) {
  storage::TetMesh m;
  m.x.assign(v.x.begin(), v.x.end());
  m.y.assign(v.y.begin(), v.y.end());
  m.z.assign(v.z.begin(), v.z.end());
  m.tets.assign(v.tets.begin(), v.tets.end());
  return m;
}

bool in_box(const float* p, const float box[6], double slack) {
  for (int k = 0; k < 3; ++k)
    if (p[k] < box[k] - slack || p[k] > box[3 + k] + slack) return false;
  return true;
}

double box_distance(const float* p, const float box[6]) {
  double d = 0;
  for (int k = 0; k < 3; ++k) {
    const double e = std::max({0.0, double(box[k]) - p[k], double(p[k]) - box[3 + k]});
    d += e * e;
  }
  return d;
}

void set_stencil(Stencil& s, const storage::SegmentView& v, const uint32_t* tet, const double w[4]) {
  double clamped[4], sum = 0;
  for (int k = 0; k < 4; ++k) sum += clamped[k] = std::max(0.0, w[k]);
  for (int k = 0; k < 4; ++k) {
    s.ids[k] = v.global_ids[tet[k]];
    s.w[k] = static_cast<float>(sum > 0 ? clamped[k] / sum : k == 0);
  }
}

// Each position's stencil: the input tet it is most inside of, over the input's segments one
// at a time (their boxes first); a position inside none takes the nearest tet of the segment
// whose box is nearest. Returns how many lie outside every tet (beyond 1e-6 in weight).
uint64_t locate(const storage::Store& store, const std::vector<float>& positions, std::vector<Stencil>& stencils) {
  const size_t n = positions.size() / 3;
  stencils.assign(n, Stencil{});
  std::vector<double> best(n, -std::numeric_limits<double>::infinity());
  const auto& level0 = store.manifest().json.at("multiresolution").at("levels").at(0);
  const uint32_t segments = level0.at("segments").get<uint32_t>();
  const auto& b = store.manifest().bounds;
  const double slack = 1e-6 * std::sqrt(std::pow(b.max[0] - b.min[0], 2) + std::pow(b.max[1] - b.min[1], 2) + std::pow(b.max[2] - b.min[2], 2));
  for (uint32_t s = 0; s < segments; ++s) {
    const auto mapped = store.map_segment(s);
    const storage::SegmentView& v = mapped->view();
    const storage::TetMesh mesh = segment_mesh(v);
    const detail::TetLocator locator(mesh);
    const float* box = store.record(s).bounds;
    for (size_t p = 0; p < n; ++p) {
      if (best[p] >= 0 || !in_box(&positions[3 * p], box, slack)) continue;
      double w[4];
      const Vec3 at{positions[3 * p], positions[3 * p + 1], positions[3 * p + 2]};
      const uint32_t t = locator.containing(at, w, std::numeric_limits<double>::max());
      if (t == detail::kNoTet) continue;
      const double worst = std::min({w[0], w[1], w[2], w[3]});
      if (worst <= best[p]) continue;
      best[p] = worst;
      set_stencil(stencils[p], v, &mesh.tets[4 * size_t{t}], w);
    }
  }
  // the rest: outside every box, or outside the tets of the boxes holding them
  std::vector<std::vector<uint32_t>> nearest(segments);
  uint64_t outside = 0;
  for (size_t p = 0; p < n; ++p) {
    if (best[p] >= -1e-6) continue;
    ++outside;
    uint32_t closest = 0;
    double d = std::numeric_limits<double>::max();
    for (uint32_t s = 0; s < segments; ++s)
      if (const double e = box_distance(&positions[3 * p], store.record(s).bounds); e < d) {
        d = e;
        closest = s;
      }
    if (std::isinf(best[p]) || d > 0) nearest[closest].push_back(static_cast<uint32_t>(p));
  }
  for (uint32_t s = 0; s < segments; ++s) {
    if (nearest[s].empty()) continue;
    const auto mapped = store.map_segment(s);
    const storage::TetMesh mesh = segment_mesh(mapped->view());
    const detail::TetLocator locator(mesh);
    for (uint32_t p : nearest[s]) {
      double w[4];
      const uint32_t t = locator.nearest({positions[3 * p], positions[3 * p + 1], positions[3 * p + 2]}, w);
      set_stencil(stencils[p], mapped->view(), &mesh.tets[4 * size_t{t}], w);
    }
  }
  return outside;
}

// "step 2 (flow_2.vtu)", "step 2 (case.exo, time step 2)"
std::string step_where(size_t index, const storage::SeriesInput& step) {
  return "step " + std::to_string(index) + " (" + step.path.string() + (step.file_step >= 0 ? ", time step " + std::to_string(step.file_step) : "") + ")";
}

[[noreturn]] void mismatch(size_t index, const storage::SeriesInput& step, const std::string& what) {
  throw storage::MeshError(step_where(index, step) + ": " + what + ": every step of a series must have the first step's mesh");
}

// Step `index` against the first step: counts, tets, attributes, coordinates.
void check_same_mesh(size_t index, const storage::SeriesInput& step, const StepData& d, const StepData& first, const storage::StoreManifest& manifest, double tolerance) {
  if (d.file_vertices != first.file_vertices) mismatch(index, step, std::to_string(d.file_vertices) + " vertices where the first step has " + std::to_string(first.file_vertices));
  if (d.tets != first.tets) mismatch(index, step, std::to_string(d.tets) + " tets where the first step has " + std::to_string(first.tets));
  if (d.tets_crc != first.tets_crc) mismatch(index, step, "its tets join other vertices than the first step's");
  std::string have, want;
  for (const auto& a : d.attributes) have += (have.empty() ? "" : ", ") + a.name + "(" + std::to_string(a.components) + ")";
  for (const auto& a : manifest.attributes) want += (want.empty() ? "" : ", ") + a.name + "(" + std::to_string(a.components) + ")";
  if (have != want) mismatch(index, step, "attributes " + (have.empty() ? std::string("none") : have) + " where the first step has " + want);
  for (size_t i = 0; i < d.xyz.size(); ++i)
    if (!(std::abs(double(d.xyz[i]) - first.xyz[i]) <= tolerance)) mismatch(index, step, "vertex " + std::to_string(i / 3) + " is elsewhere than in the first step");
}

// Every value of a step is finite: steps.bin holds finite values only, and a vertex of no
// value (NaN: a node a field leaves out) would have none to show at that step.
void check_finite(size_t index, const storage::SeriesInput& step, const StepData& d, const storage::StoreManifest& manifest, uint32_t floats) {
  for (size_t i = 0; i < d.values.size(); ++i) {
    if (std::isfinite(d.values[i])) continue;
    size_t column = i % floats, a = 0;
    while (column >= manifest.attributes[a].components) column -= manifest.attributes[a++].components;
    throw storage::MeshError(step_where(index, step) + ": attribute '" + manifest.attributes[a].name + "' at vertex " + std::to_string(i / floats) + " is " + std::to_string(d.values[i]) +
                             ": every value of every step of a series must be finite");
  }
}

// The block of one step, and each attribute's range over the input's vertices.
std::vector<float> step_block(const StepData& d, const storage::StepLayout& layout, const std::vector<Stencil>& stencils, const storage::StoreManifest& manifest,
                              std::vector<std::array<double, 2>>& ranges) {
  const uint32_t f = layout.floats;
  std::vector<float> block(layout.rows() * f);
  std::copy(d.values.begin(), d.values.end(), block.begin());
  for (size_t p = 0; p < stencils.size(); ++p) {
    float* out = block.data() + (layout.input_vertices + p) * f;
    for (uint32_t k = 0; k < f; ++k) {
      double v = 0;
      for (int c = 0; c < 4; ++c) v += double(stencils[p].w[c]) * d.values[size_t{stencils[p].ids[c]} * f + k];
      out[k] = static_cast<float>(v);
    }
  }
  ranges.clear();
  for (size_t a = 0, offset = 0; a < manifest.attributes.size(); offset += manifest.attributes[a].components, ++a) {
    const uint32_t c = manifest.attributes[a].components;
    double lo = INFINITY, hi = -INFINITY;
    for (uint64_t v = 0; v < layout.input_vertices; ++v) {
      const double x = attribute_scalar(block.data() + v * f + offset, c);
      lo = std::min(lo, x);
      hi = std::max(hi, x);
    }
    ranges.push_back({lo, hi});
  }
  return block;
}

SeriesReport add_steps(const std::vector<storage::SeriesInput>& steps, const fs::path& directory, const PreprocessOptions& options, storage::Progress* progress) {
  const auto start = std::chrono::steady_clock::now();
  SeriesReport report;
  report.steps = static_cast<uint32_t>(steps.size());
  auto store = storage::Store::open(directory);
  const storage::StoreManifest& manifest = store->manifest();
  storage::StepLayout layout;
  layout.store_vertices = manifest.vertex_count;
  layout.input_vertices = manifest.json.at("multiresolution").at("input").at("vertices").get<uint64_t>();
  for (const auto& a : manifest.attributes) layout.floats += a.components;
  if (layout.floats == 0) throw storage::MeshError(steps[0].path.string() + ": the first step has no attributes: a series without values has nothing to show");
  std::vector<float> positions;
  {
    std::shared_ptr<const VertexHierarchy> hierarchy = open_vertex_hierarchy(directory);
    layout.collapses = hierarchy ? hierarchy->collapse_count() : 0;
    positions = interpolated_positions(*store, layout, hierarchy.get());
  }
  std::vector<Stencil> stencils;
  report.interpolated_vertices = positions.size() / 3;
  report.outside_vertices = locate(*store, positions, stencils);
  positions = {};
  const StepData first = read_step(steps[0], layout.floats, options.read_limits);
  if (first.xyz.size() / 3 != layout.input_vertices) mismatch(0, steps[0], "it changed while the store was built");
  check_finite(0, steps[0], first, manifest, layout.floats);
  const auto& b = manifest.bounds;
  const double tolerance = 1e-6 * std::sqrt(std::pow(b.max[0] - b.min[0], 2) + std::pow(b.max[1] - b.min[1], 2) + std::pow(b.max[2] - b.min[2], 2));
  std::vector<storage::TimeStep> listed;
  {
    std::vector<std::array<double, 2>> ranges;
    step_block(first, layout, stencils, manifest, ranges);
    listed.push_back({0, steps[0].time, steps[0].name, ranges});
  }
  storage::TimeStepsWriter writer(directory / storage::kTimeStepsFile, layout, report.steps);
  for (size_t i = 1; i < steps.size(); ++i) {
    if (progress) progress->update(double(i) / double(steps.size()));
    const StepData d = read_step(steps[i], layout.floats, options.read_limits);
    check_same_mesh(i, steps[i], d, first, manifest, tolerance);
    check_finite(i, steps[i], d, manifest, layout.floats);
    std::vector<std::array<double, 2>> ranges;
    writer.add(step_block(d, layout, stencils, manifest, ranges));
    listed.push_back({static_cast<uint32_t>(i), steps[i].time, steps[i].name, ranges});
  }
  report.steps_bytes = writer.finish();
  nlohmann::json json = manifest.json;
  json["time_steps"] = storage::time_steps_manifest(listed, layout, report.steps_bytes);
  storage::write_manifest(directory / "manifest.json", json);
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return report;
}

}  // namespace

SeriesReport preprocess_series(const std::vector<storage::SeriesInput>& steps, const fs::path& store, const PreprocessOptions& options, storage::Progress* progress,
                               PreprocessReport* build) {
  if (steps.size() < 2) throw std::invalid_argument("a time series has two or more steps");
  if (options.variants > 0) throw std::invalid_argument("--variants is not built for a time series (a variant's own vertices have no values of the further steps)");
  if (options.ranks && options.ranks->size() > 1) throw std::invalid_argument("a time series is preprocessed by one process (not under mpirun)");
  fs::path target = store;
  if (target.filename().empty()) target = target.parent_path();
  std::error_code ec;
  if (fs::exists(target, ec) && !options.replace) throw std::runtime_error(target.string() + ": already exists (use --force to replace it)");
  fs::path building = target;
  building += ".series";
  fs::remove_all(building, ec);
  PreprocessOptions first = options;
  first.replace = true;
  first.read_limits = step_limits(steps[0], options.read_limits);
  PreprocessReport report = preprocess(steps[0].path, building, first, progress);
  if (build) *build = report;
  SeriesReport series;
  try {
    if (progress) progress->begin("steps");
    series = add_steps(steps, building, options, progress);
    if (fs::exists(target, ec)) fs::remove_all(target);
    fs::rename(building, target);
  } catch (...) {
    fs::remove_all(building, ec);
    throw;
  }
  return series;
}

}  // namespace tetrascope::lod
