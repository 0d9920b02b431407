// The global tetrahedral simplifier of dissertation §4.2 [SS06a]: the border is simplified
// without self-intersections (§4.2.1, simplify_sample_border.cpp), the interior point-sampled
// by an octree split by field and space error, one representative point a leaf (§4.2.2), and
// TetGen [Si05] builds a constrained Delaunay tetrahedralization of the samples inside the
// simplified border (§4.2.3); Steiner points get values by barycentric location in the input,
// walking from tet to tet across faces.
#define TETLIBRARY
#include <fcntl.h>
#include <sys/wait.h>
#include <tetgen.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <mutex>
#include <queue>
#include <stdexcept>
#include <string>

#include "simplify_sample.h"
#include "tet_locator.h"
#include "tetrascope/lod/simplify/border_intersection.h"
#include "tetrascope/lod/simplify/simplify.h"
#include "tetrascope/storage/sanitizer.h"
#include "tetrascope/storage/tensor.h"

namespace tetrascope::lod {
namespace {

using detail::Box3;
using detail::Point3;

constexpr uint32_t kSteiner = 0xFFFFFFFFu;
constexpr int kMaxOctreeDepth = 30;
// A constrained Delaunay tetrahedralization has about this many tets per interior point and
// per border point (measured on the shared data; the estimate sets the sample count of a
// target, corrected once when it misses by more than kTargetSlack).
constexpr double kTetsPerInteriorPoint = 6.0;
constexpr double kTetsPerBorderPoint = 1.5;
constexpr double kTargetSlack = 0.15;
// Without a threshold, leaves are split by D (|a_max - a_min| + kSizeWeight): the space error
// with a floor, so that regions of constant values are still sampled evenly.
constexpr double kSizeWeight = 0.05;
// A border collapse that drops values differing by the whole normalised range costs as much
// as one moving the border by this share of the diagonal: flat regions of even values go first.
constexpr double kBorderFieldWeight = 0.05;
// Border collapses costing less than moving the border by this share of the diagonal (or
// changing the values by kFreeBorderCost / kBorderFieldWeight of their range) are made past
// the border's share of the target too, and the tets they free go to interior samples.
constexpr double kFreeBorderCost = 1e-4;

double sq(double x) { return x * x; }

// Normalised attribute channels (§4.2.2): scalars to [0, 1] by their range, vectors by the
// longest vector to 0.5 v + 0.5. Returns per vertex `channels` values.
std::vector<float> normalised_channels(const storage::TetMesh& mesh, const SimplifyOptions& options, size_t* channel_count) {
  struct Channel {
    const std::vector<float>* values;
    uint32_t components, component;
    double offset, scale;
  };
  std::vector<Channel> channels;
  for (const std::string& name : options.attributes)
    if (!mesh.find_attribute(name)) throw std::invalid_argument("no attribute '" + name + "' in the mesh");
  if (!options.attribute_ranges.empty() && options.attribute_ranges.size() != mesh.attributes.size())
    throw std::invalid_argument("attribute_ranges must give one range per attribute");
  for (size_t a = 0; a < mesh.attributes.size(); ++a) {
    const auto& attribute = mesh.attributes[a];
    if (!options.attributes.empty() && std::find(options.attributes.begin(), options.attributes.end(), attribute.info.name) == options.attributes.end()) continue;
    // a tensor's derived scalars are recomputed from it afterwards: weighed only when named
    if (options.attributes.empty() && attribute.info.kind == storage::AttributeKind::kTensorDerived) continue;
    const uint32_t c = attribute.info.components;
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    if (!options.attribute_ranges.empty()) {
      lo = options.attribute_ranges[a][0];
      hi = options.attribute_ranges[a][1];
    } else if (c == 1) {
      for (float v : attribute.values)
        if (std::isfinite(v)) lo = std::min<double>(lo, v), hi = std::max<double>(hi, v);
    } else {
      lo = 0;
      hi = 0;
      for (size_t v = 0; v < attribute.values.size() / c; ++v) {
        double s = 0;
        for (uint32_t k = 0; k < c; ++k) s += double(attribute.values[v * c + k]) * attribute.values[v * c + k];
        if (std::isfinite(s)) hi = std::max(hi, std::sqrt(s));
      }
    }
    for (uint32_t k = 0; k < c; ++k) {
      if (c == 1) channels.push_back({&attribute.values, c, k, std::isfinite(lo) ? lo : 0, hi > lo ? 1.0 / (hi - lo) : 0});
      else channels.push_back({&attribute.values, c, k, 0, hi > 0 ? 0.5 / hi : 0});
    }
  }
  *channel_count = channels.size();
  const size_t nv = mesh.vertex_count();
  std::vector<float> out(nv * channels.size());
  for (size_t i = 0; i < channels.size(); ++i) {
    const Channel& ch = channels[i];
    for (size_t v = 0; v < nv; ++v) {
      const double raw = (*ch.values)[v * ch.components + ch.component];
      double value = ch.components == 1 ? (raw - ch.offset) * ch.scale : raw * ch.scale + 0.5;
      if (!std::isfinite(value)) value = 0;
      out[v * channels.size() + i] = static_cast<float>(value);
    }
  }
  return out;
}

// Octree point sampling (§4.2.2): returns one representative vertex per leaf.
class PointSampler {
 public:
  PointSampler(const std::vector<Point3>& positions, const std::vector<float>& values, size_t channels, double extent)
      : positions_(positions), values_(values), channels_(channels), extent_(extent > 0 ? extent : 1) {}

  std::vector<uint32_t> sample(std::vector<uint32_t> points, const SimplifyOptions& options, uint64_t wanted) {
    std::vector<uint32_t> out;
    if (points.empty()) return out;
    points_ = std::move(points);
    scratch_.resize(points_.size());
    Box3 cell;
    for (uint32_t v : points_) cell.add(positions_[v]);
    double side = 0;
    for (int k = 0; k < 3; ++k) side = std::max(side, cell.hi[k] - cell.lo[k]);
    for (int k = 0; k < 3; ++k) cell.hi[k] = cell.lo[k] + side * (1 + 1e-9) + 1e-30;
    const bool thresholds = options.field_error > 0 || options.space_error > 0;
    std::priority_queue<Leaf> open;
    std::vector<Leaf> done;
    open.push(make_leaf(0, static_cast<uint32_t>(points_.size()), cell, 0, options, thresholds));
    uint64_t leaves = 1;
    while (!open.empty()) {
      Leaf leaf = open.top();
      if ((wanted && leaves >= wanted) || (thresholds && leaf.priority <= 1)) break;
      open.pop();
      if (leaf.end - leaf.begin <= 1 || leaf.depth >= kMaxOctreeDepth || leaf.priority <= 0) {
        done.push_back(leaf);
        continue;
      }
      // split at the mid-point, points spread over the children in place
      uint32_t count[8] = {0}, first[9] = {0};
      auto octant = [&](uint32_t v) {
        uint32_t o = 0;
        for (int k = 0; k < 3; ++k)
          if (positions_[v][k] >= 0.5 * (leaf.cell.lo[k] + leaf.cell.hi[k])) o |= 1u << k;
        return o;
      };
      for (uint32_t i = leaf.begin; i < leaf.end; ++i) ++count[octant(points_[i])];
      first[0] = leaf.begin;
      for (int c = 0; c < 8; ++c) first[c + 1] = first[c] + count[c];
      uint32_t fill[8];
      std::copy(first, first + 8, fill);
      for (uint32_t i = leaf.begin; i < leaf.end; ++i) scratch_[fill[octant(points_[i])]++] = points_[i];
      std::copy(scratch_.begin() + leaf.begin, scratch_.begin() + leaf.end, points_.begin() + leaf.begin);
      int children = 0;
      for (uint32_t c = 0; c < 8; ++c) {
        if (count[c] == 0) continue;
        Box3 child;
        for (int k = 0; k < 3; ++k) {
          const double mid = 0.5 * (leaf.cell.lo[k] + leaf.cell.hi[k]);
          child.lo[k] = (c >> k) & 1 ? mid : leaf.cell.lo[k];
          child.hi[k] = (c >> k) & 1 ? leaf.cell.hi[k] : mid;
        }
        open.push(make_leaf(first[c], first[c + 1], child, leaf.depth + 1, options, thresholds));
        ++children;
      }
      leaves += children - 1;
    }
    while (!open.empty()) {
      done.push_back(open.top());
      open.pop();
    }
    for (const Leaf& leaf : done) out.push_back(representative(leaf));
    std::sort(out.begin(), out.end());
    return out;
  }

 private:
  struct Leaf {
    uint32_t begin, end;
    Box3 cell;
    int depth;
    double priority;
    bool operator<(const Leaf& o) const { return priority != o.priority ? priority < o.priority : begin > o.begin; }
  };

  Leaf make_leaf(uint32_t begin, uint32_t end, const Box3& cell, int depth, const SimplifyOptions& options, bool thresholds) const {
    double spread = 0;
    for (size_t c = 0; c < channels_; ++c) {
      float lo = values_[size_t{points_[begin]} * channels_ + c], hi = lo;
      for (uint32_t i = begin + 1; i < end; ++i) {
        const float v = values_[size_t{points_[i]} * channels_ + c];
        lo = std::min(lo, v);
        hi = std::max(hi, v);
      }
      spread += double(hi - lo) * (hi - lo);
    }
    const double field = std::sqrt(spread), relative_extent = (cell.hi[0] - cell.lo[0]) / extent_;
    if (!thresholds) {
      const double priority = end - begin <= 1 ? 0 : nonlinearity(begin, end, cell) + double(end - begin) * sq(kSizeWeight * relative_extent);
      return {begin, end, cell, depth, priority};
    }
    double priority = 0;
    if (thresholds) {
      if (options.field_error > 0) priority = std::max(priority, field / options.field_error);
      if (options.space_error > 0) priority = std::max(priority, relative_extent * field / options.space_error);
      // past the thresholds a target still asks for more points: the largest leaves next
      if (priority <= 1 && options.target_tets) priority = 1e-9 * relative_extent * (field + kSizeWeight);
    } else {
      priority = relative_extent * (field + kSizeWeight);
    }
    if (end - begin <= 1) priority = 0;
    return {begin, end, cell, depth, priority};
  }

  // The leaf's squared error against its values' least-squares linear fit (every channel, in
  // normalised units, summed over its points): what a linear interpolant of one leaf misses,
  // so a leaf where the field bends or oscillates is split first, a linear one never for its
  // values alone.
  double nonlinearity(uint32_t begin, uint32_t end, const Box3& cell) const {
    if (channels_ == 0 || end - begin < 5) return 0;
    double a[4][4] = {}, c[3], scale = 0;
    for (int k = 0; k < 3; ++k) c[k] = 0.5 * (cell.lo[k] + cell.hi[k]), scale = std::max(scale, cell.hi[k] - cell.lo[k]);
    scale = scale > 0 ? 1 / scale : 1;
    b_.assign(4 * channels_, 0.0);
    s_.assign(channels_, 0.0);
    for (uint32_t i = begin; i < end; ++i) {
      const uint32_t v = points_[i];
      const double u[4] = {(positions_[v][0] - c[0]) * scale, (positions_[v][1] - c[1]) * scale, (positions_[v][2] - c[2]) * scale, 1};
      for (int r = 0; r < 4; ++r)
        for (int q = r; q < 4; ++q) a[r][q] += u[r] * u[q];
      const float* f = &values_[size_t{v} * channels_];
      for (size_t ch = 0; ch < channels_; ++ch) {
        for (int r = 0; r < 4; ++r) b_[4 * ch + r] += f[ch] * u[r];
        s_[ch] += double(f[ch]) * f[ch];
      }
    }
    // Cholesky of the 4x4 moments (a small ridge for points in a plane or on a line)
    double l[4][4] = {};
    const double ridge = 1e-9 * (a[0][0] + a[1][1] + a[2][2] + a[3][3]);
    for (int r = 0; r < 4; ++r)
      for (int q = 0; q <= r; ++q) {
        double sum = a[q][r] + (q == r ? ridge : 0);
        for (int k = 0; k < q; ++k) sum -= l[r][k] * l[q][k];
        if (q == r) l[r][r] = std::sqrt(std::max(sum, 1e-300));
        else l[r][q] = sum / l[q][q];
      }
    double total = 0;
    for (size_t ch = 0; ch < channels_; ++ch) {
      double y[4];  // b^T A^-1 b = |L^-1 b|^2
      double fitted = 0;
      for (int r = 0; r < 4; ++r) {
        double sum = b_[4 * ch + r];
        for (int k = 0; k < r; ++k) sum -= l[r][k] * y[k];
        y[r] = sum / l[r][r];
        fitted += y[r] * y[r];
      }
      total += std::max(0.0, s_[ch] - fitted);
    }
    return total;
  }

  // the point closest to the leaf's centroid: samples spread evenly, so the tets between them
  // are well shaped (the values follow by the least-squares fit; a point of mean value sat
  // anywhere in a leaf with a gradient, measured worse on ONERA and an oscillatory cube)
  uint32_t representative(const Leaf& leaf) const {
    double mean[3] = {0, 0, 0};
    for (uint32_t i = leaf.begin; i < leaf.end; ++i)
      for (int c = 0; c < 3; ++c) mean[c] += positions_[points_[i]][c];
    for (double& m : mean) m /= double(leaf.end - leaf.begin);
    uint32_t best = points_[leaf.begin];
    double best_distance = std::numeric_limits<double>::infinity();
    for (uint32_t i = leaf.begin; i < leaf.end; ++i) {
      double d = 0;
      for (int c = 0; c < 3; ++c) d += sq(positions_[points_[i]][c] - mean[c]);
      if (d < best_distance) best_distance = d, best = points_[i];
    }
    return best;
  }

  const std::vector<Point3>& positions_;
  const std::vector<float>& values_;
  size_t channels_;
  double extent_;
  std::vector<uint32_t> points_, scratch_;
  mutable std::vector<double> b_, s_;
};

struct Tetrahedralization {
  std::vector<Point3> steiner;    // points TetGen added
  std::vector<uint32_t> tets;     // 4 per tet: < inputs: input point; else inputs + Steiner index
};

// Constrained Delaunay tetrahedralization of `points` (the border's vertices first) bounded by
// `triangles` (indices into points), with no point added on the border (-Y).
// The mesh simplified by quadric collapses instead, reported as such.
SimplifyReport fall_back_to_qem(storage::TetMesh& mesh, const SimplifyOptions& options, const std::vector<uint8_t>& locked,
                                const SimplifyReport& sampled) {
  SimplifyOptions qem = options;
  qem.method = SimplifyMethod::kQem;
  SimplifyReport fallback = simplify(mesh, qem, locked);
  fallback.fell_back_to_qem = true;
  fallback.border_before = sampled.border_before;
  fallback.tetgen_failure = sampled.tetgen_failure;
  return fallback;
}

Tetrahedralization tetrahedralize_samples(const std::vector<Point3>& points, const std::vector<std::array<uint32_t, 3>>& triangles) {
  tetgenio in, out;
  in.firstnumber = 0;
  in.numberofpoints = static_cast<int>(points.size());
  in.pointlist = new REAL[3 * points.size()];
  for (size_t i = 0; i < points.size(); ++i)
    for (int k = 0; k < 3; ++k) in.pointlist[3 * i + k] = points[i][k];
  in.numberoffacets = static_cast<int>(triangles.size());
  in.facetlist = new tetgenio::facet[triangles.size()];
  for (size_t i = 0; i < triangles.size(); ++i) {
    tetgenio::facet& f = in.facetlist[i];
    tetgenio::init(&f);
    f.numberofpolygons = 1;
    f.polygonlist = new tetgenio::polygon[1];
    tetgenio::init(&f.polygonlist[0]);
    f.polygonlist[0].numberofvertices = 3;
    f.polygonlist[0].vertexlist = new int[3];
    for (int k = 0; k < 3; ++k) f.polygonlist[0].vertexlist[k] = static_cast<int>(triangles[i][k]);
  }
  tetgenbehavior behaviour;
  char switches[] = "pYQzJ";
  if (!behaviour.parse_commandline(switches)) throw std::runtime_error("tetgen: bad switches");
  // the static filter is global state in TetGen's predicates, which border_intersection.cpp
  // also calls (exactinit without it): a run in this process must not switch it on
  behaviour.nostaticfilter = 1;
  try {
    tetrahedralize(&behaviour, &in, &out);
  } catch (int code) {
    throw std::runtime_error("tetgen could not tetrahedralize the sampled mesh (code " + std::to_string(code) +
                             (code == 3 ? ": the border intersects itself)" : ")"));
  }
  Tetrahedralization result;
  const int inputs = static_cast<int>(points.size());
  for (int i = inputs; i < out.numberofpoints; ++i) result.steiner.push_back({out.pointlist[3 * i], out.pointlist[3 * i + 1], out.pointlist[3 * i + 2]});
  result.tets.assign(out.tetrahedronlist, out.tetrahedronlist + 4 * size_t(out.numberoftetrahedra));
  return result;
}

// TetGen 1.5 as Debian builds it keeps its assertions, and a failed one ends the process
// (recoveredgebyflips on ONERA's levels; freememory after a failure on the 5M blade), and its
// predicates and tables are globals. So each run is a child process of its own: a crash there
// is an error here, and runs on several threads do not share TetGen's state. The child sends
// the result through a pipe: a status byte, then the Steiner points and the tets, or a message.
// The child, forked from a process with threads, uses only TetGen, malloc, stdio and write;
// glibc makes malloc and stdio usable after fork.
Tetrahedralization tetrahedralize_apart(const std::vector<Point3>& points, const std::vector<std::array<uint32_t, 3>>& triangles) {
  if constexpr (storage::kAddressSanitizer) {
    // ASan's allocator is not safe to use in a child forked from several threads (the child
    // waited forever on a lock another thread held at the fork): sanitized builds run TetGen
    // here, one run at a time, as before (a failed assertion then ends the process).
    static std::mutex one_at_a_time;
    std::lock_guard lock(one_at_a_time);
    return tetrahedralize_samples(points, triangles);
  }
  int fds[2];
  if (::pipe2(fds, O_CLOEXEC) != 0) throw std::runtime_error(std::string("tetgen: cannot make a pipe: ") + std::strerror(errno));
  const pid_t pid = ::fork();
  if (pid < 0) {
    ::close(fds[0]);
    ::close(fds[1]);
    throw std::runtime_error(std::string("tetgen: cannot start a process: ") + std::strerror(errno));
  }
  if (pid == 0) {  // child: one thread (the caller's), its own copy of memory; never returns
    ::close(fds[0]);
    auto send = [&](const void* data, size_t bytes) {
      const char* at = static_cast<const char*>(data);
      while (bytes > 0) {
        const ssize_t n = ::write(fds[1], at, bytes);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) ::_exit(3);
        at += n;
        bytes -= static_cast<size_t>(n);
      }
    };
    try {
      const Tetrahedralization r = tetrahedralize_samples(points, triangles);
      const uint64_t counts[2] = {r.steiner.size(), r.tets.size()};
      send("\0", 1);
      send(counts, sizeof counts);
      send(r.steiner.data(), r.steiner.size() * sizeof(Point3));
      send(r.tets.data(), r.tets.size() * sizeof(uint32_t));
    } catch (const std::exception& e) {
      const std::string message = e.what();
      send("\1", 1);
      send(message.data(), message.size());
    }
    ::_exit(0);
  }
  ::close(fds[1]);
  std::string bytes;
  char buffer[1 << 16];
  for (;;) {
    const ssize_t n = ::read(fds[0], buffer, sizeof buffer);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    bytes.append(buffer, static_cast<size_t>(n));
  }
  ::close(fds[0]);
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (WIFSIGNALED(status))
    throw std::runtime_error(std::string("tetgen crashed on the sampled mesh (signal ") + std::to_string(WTERMSIG(status)) + ", " + strsignal(WTERMSIG(status)) + ")");
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0 || bytes.empty()) throw std::runtime_error("tetgen's process ended without a result");
  if (bytes[0] == 1) throw std::runtime_error(bytes.substr(1));
  uint64_t counts[2];
  if (bytes.size() < 1 + sizeof counts) throw std::runtime_error("tetgen's process sent a short result");
  std::memcpy(counts, bytes.data() + 1, sizeof counts);
  const size_t expect = 1 + sizeof counts + counts[0] * sizeof(Point3) + counts[1] * sizeof(uint32_t);
  if (bytes.size() != expect) throw std::runtime_error("tetgen's process sent a short result");
  Tetrahedralization r;
  r.steiner.resize(counts[0]);
  r.tets.resize(counts[1]);
  if (counts[0] > 0) std::memcpy(r.steiner.data(), bytes.data() + 1 + sizeof counts, counts[0] * sizeof(Point3));  // (no Steiner points: data() may be null)
  if (counts[1] > 0) std::memcpy(r.tets.data(), bytes.data() + 1 + sizeof counts + counts[0] * sizeof(Point3), counts[1] * sizeof(uint32_t));
  return r;
}

// Throws std::invalid_argument for locked flags or options the sampling simplifier cannot use.
void check_sample_options(const SimplifyOptions& options, const std::vector<uint8_t>& locked, size_t nv) {
  if (!locked.empty() && locked.size() != nv) throw std::invalid_argument("locked flags must cover every vertex");
  if (!(options.field_error >= 0 && std::isfinite(options.field_error))) throw std::invalid_argument("the field error threshold must be a finite number >= 0");
  if (!(options.space_error >= 0 && std::isfinite(options.space_error))) throw std::invalid_argument("the space error threshold must be a finite number >= 0");
  if (!(options.border_error >= 0 && options.border_error <= 1)) throw std::invalid_argument("the border error must be in [0, 1] (a share of the diagonal)");
  if (options.target_tets == 0 && options.field_error == 0 && options.space_error == 0)
    throw std::invalid_argument("the sampling simplifier needs a target tet count, a field error or a space error threshold");
}

// Adds the seconds since the previous lap (the first: since it was made) to a phase's total.
class Lap {
 public:
  void operator()(double& into) {
    const auto now = std::chrono::steady_clock::now();
    into += std::chrono::duration<double>(now - last_).count();
    last_ = now;
  }

 private:
  std::chrono::steady_clock::time_point last_ = std::chrono::steady_clock::now();
};

// 1. the border, simplified without self-intersections (§4.2.1), towards the target's share
// of its triangles; the counts go into report.
detail::BorderSimplifyResult simplify_mesh_border(const storage::TetMesh& mesh, const SimplifyOptions& options, const std::vector<uint8_t>& locked,
                                                  const std::vector<Point3>& positions, const std::vector<std::array<uint32_t, 3>>& border,
                                                  const detail::BorderField& field, double diagonal, SimplifyReport& report) {
  const double ratio = options.target_tets ? std::min(1.0, double(options.target_tets) / std::max<double>(1, double(mesh.tet_count()))) : 0.0;
  const uint64_t border_target = static_cast<uint64_t>(double(border.size()) * std::pow(ratio, 2.0 / 3.0));
  detail::BorderSimplifyResult simplified = detail::simplify_border(positions, border, locked, border_target, options.border_error * diagonal, field);
  report.border_after = simplified.triangles.size();
  report.refused_intersection = simplified.refused_intersection;
  report.refused_topology = simplified.refused_topology;
  report.refused_geometry = simplified.refused_geometry;
  report.collapses = simplified.collapses;
  return simplified;
}

// 2. the interior points: used, not on the original border, not locked
std::vector<uint32_t> interior_points(const storage::TetMesh& mesh, const std::vector<std::array<uint32_t, 3>>& border, const std::vector<uint8_t>& locked) {
  const size_t nv = mesh.vertex_count();
  std::vector<uint8_t> kind(nv, 0);  // 1 used, 2 on the original border or locked
  for (uint32_t v : mesh.tets) kind[v] = std::max<uint8_t>(kind[v], 1);
  for (const auto& f : border)
    for (uint32_t v : f) kind[v] = 2;
  for (size_t v = 0; v < locked.size(); ++v)
    if (locked[v]) kind[v] = 2;
  std::vector<uint32_t> interior;
  for (uint32_t v = 0; v < nv; ++v)
    if (kind[v] == 1) interior.push_back(v);
  return interior;
}

// The tetrahedralization's points as input vertex ids (the simplified border's vertices, then
// the samples) and the border's facets in their indices.
struct TetPoints {
  std::vector<uint32_t> input_vertex;
  size_t border_points = 0;
  std::vector<std::array<uint32_t, 3>> facets;
};

// The simplified border's vertices (ascending) as the first points, and its triangles as
// facets over them; nv is the input's vertex count.
TetPoints border_points_and_facets(const std::vector<std::array<uint32_t, 3>>& triangles, size_t nv) {
  TetPoints tet_points;
  std::vector<uint32_t>& input_vertex = tet_points.input_vertex;
  {
    std::vector<uint8_t> on_border(nv, 0);
    for (const auto& f : triangles)
      for (uint32_t v : f) on_border[v] = 1;
    for (uint32_t v = 0; v < nv; ++v)
      if (on_border[v]) input_vertex.push_back(v);
  }
  tet_points.border_points = input_vertex.size();
  const size_t border_points = tet_points.border_points;
  std::vector<uint32_t> border_index(nv, kSteiner);
  for (uint32_t i = 0; i < border_points; ++i) border_index[input_vertex[i]] = i;
  std::vector<std::array<uint32_t, 3>>& facets = tet_points.facets;
  facets.resize(triangles.size());
  for (size_t i = 0; i < facets.size(); ++i)
    for (int k = 0; k < 3; ++k) facets[i][k] = border_index[triangles[i][k]];
  return tet_points;
}

// Whether the simplified border's facets cross each other.
bool border_crosses_itself(const std::vector<Point3>& positions, const TetPoints& tet_points) {
  std::vector<Point3> border_positions(tet_points.border_points);
  for (size_t i = 0; i < tet_points.border_points; ++i) border_positions[i] = positions[tet_points.input_vertex[i]];
  return !detail::self_intersections(border_positions, tet_points.facets, 1).empty();
}

// 3. sample and tetrahedralize (§4.2.2-4.2.3); once more when the target was missed by far.
// Fills samples and tetrahedra; returns false when TetGen failed (report.tetgen_failure says
// how).
bool sample_and_tetrahedralize(PointSampler& sampler, const std::vector<uint32_t>& interior, const std::vector<Point3>& positions, const TetPoints& tet_points,
                               const SimplifyOptions& options, const std::vector<uint8_t>& locked, Lap& lap, SimplifyReport& report,
                               std::vector<uint32_t>& samples, Tetrahedralization& tetrahedra) {
  const std::vector<uint32_t>& input_vertex = tet_points.input_vertex;
  const size_t border_points = tet_points.border_points;
  auto wanted_samples = [&](double tets_per_interior, double tets_per_border) -> uint64_t {
    if (!options.target_tets) return 0;
    const double rest = double(options.target_tets) - tets_per_border * double(border_points);
    return static_cast<uint64_t>(std::max(1.0, rest / tets_per_interior));
  };
  uint64_t wanted = wanted_samples(kTetsPerInteriorPoint, kTetsPerBorderPoint);
  for (int attempt = 0; attempt < 2; ++attempt) {
    samples = sampler.sample(interior, options, wanted);
    lap(report.sample_seconds);
    std::vector<Point3> points(border_points + samples.size());
    for (size_t i = 0; i < border_points; ++i) points[i] = positions[input_vertex[i]];
    for (size_t i = 0; i < samples.size(); ++i) points[border_points + i] = positions[samples[i]];
    try {
      tetrahedra = tetrahedralize_apart(points, tet_points.facets);
    } catch (const std::runtime_error& e) {
      report.tetgen_failure = e.what();
      return false;
    }
    lap(report.tetrahedralize_seconds);
    ++report.tetrahedralizations;
    const double tets = double(tetrahedra.tets.size() / 4);
    if (!options.target_tets || !locked.empty() || samples.empty() || std::abs(tets - double(options.target_tets)) <= kTargetSlack * double(options.target_tets))
      break;
    // tets per sample seen in this run, the border's share as estimated
    const double border_tets = std::min(tets * 0.9, kTetsPerBorderPoint * double(border_points));
    const double per_sample = std::max(1.0, (tets - border_tets) / double(samples.size()));
    const double rest = double(options.target_tets) - border_tets;
    const uint64_t next = static_cast<uint64_t>(std::max(1.0, rest / per_sample));
    if (next == wanted) break;
    wanted = next;
  }
  return true;
}

// Marks in new_index (0) every point the tets use.
void mark_used_points(const Tetrahedralization& tetrahedra, std::vector<uint32_t>& new_index) {
  for (uint32_t i : tetrahedra.tets) new_index[i] = 0;
}

// 4. the output mesh: the points the tets use (input order, with their values), then the
// Steiner points (values by barycentric location in mesh), tets positively oriented; each
// output vertex's source goes into report. input_vertex: the first `inputs` points' vertices.
storage::TetMesh assemble_output(const storage::TetMesh& mesh, const std::vector<uint32_t>& input_vertex, size_t inputs, const Tetrahedralization& tetrahedra,
                                 SimplifyReport& report) {
  std::vector<uint32_t> new_index(inputs + tetrahedra.steiner.size(), kSteiner);
  mark_used_points(tetrahedra, new_index);
  storage::TetMesh out;
  for (const auto& a : mesh.attributes) out.attributes.push_back({a.info, {}});
  std::unique_ptr<detail::TetLocator> locator;  // made at the first Steiner point
  for (uint32_t i = 0; i < new_index.size(); ++i) {
    if (new_index[i] == kSteiner) continue;
    new_index[i] = static_cast<uint32_t>(out.x.size());
    if (i < inputs) {
      const uint32_t v = input_vertex[i];
      out.x.push_back(mesh.x[v]);
      out.y.push_back(mesh.y[v]);
      out.z.push_back(mesh.z[v]);
      for (size_t a = 0; a < mesh.attributes.size(); ++a) {
        const uint32_t c = mesh.attributes[a].info.components;
        out.attributes[a].values.insert(out.attributes[a].values.end(), mesh.attributes[a].values.begin() + size_t{v} * c,
                                        mesh.attributes[a].values.begin() + size_t{v + 1} * c);
      }
      report.source_vertex.push_back(v);
      continue;
    }
    const Point3& p = tetrahedra.steiner[i - inputs];
    out.x.push_back(static_cast<float>(p[0]));
    out.y.push_back(static_cast<float>(p[1]));
    out.z.push_back(static_cast<float>(p[2]));
    if (!locator) locator = std::make_unique<detail::TetLocator>(mesh);
    // the input tet holding the point (or nearest it, the weights clamped to it)
    double w[4] = {1, 0, 0, 0};
    const uint32_t t = mesh.tets.empty() ? 0 : locator->nearest(p, w);
    for (size_t a = 0; a < mesh.attributes.size(); ++a) {
      const uint32_t c = mesh.attributes[a].info.components;
      for (uint32_t k = 0; k < c; ++k) {
        double value = 0;
        for (int j = 0; j < 4; ++j) value += w[j] * mesh.attributes[a].values[size_t{mesh.tets[4 * size_t{t} + j]} * c + k];
        out.attributes[a].values.push_back(static_cast<float>(value));
      }
    }
    report.source_vertex.push_back(kSteiner);
    ++report.steiner_points;
  }
  out.tets.resize(tetrahedra.tets.size());
  for (size_t i = 0; i < tetrahedra.tets.size(); ++i) out.tets[i] = new_index[tetrahedra.tets[i]];
  for (size_t t = 0; t < out.tet_count(); ++t) {
    uint32_t* v = &out.tets[4 * t];
    if (storage::signed_volume(out, v[0], v[1], v[2], v[3]) < 0) std::swap(v[2], v[3]);
  }
  storage::refresh_tensor_attributes(out);  // Steiner points' tensors: kept PSD where the input was, derived scalars recomputed
  return out;
}

}  // namespace

SimplifyMethod choose_simplify_method(const storage::TetMesh& mesh, const SimplifyOptions& options, std::string* why) {
  auto choose = [&](SimplifyMethod method, const std::string& reason) {
    if (why) *why = reason;
    return method;
  };
  if (options.target_tets == 0 || options.max_error > 0) return choose(SimplifyMethod::kQem, "an error bound: the quadric simplifier's criterion");
  if (options.target_tets >= mesh.tet_count()) return choose(SimplifyMethod::kQem, "nothing to remove: the quadric simplifier returns the mesh as it is");
  if (mesh.tet_count() < kAutoSampleMinTets)
    return choose(SimplifyMethod::kQem, "fewer than " + std::to_string(kAutoSampleMinTets) + " tets: smaller than any mesh the sampler was measured on");
  {
    std::vector<uint8_t> on_border(mesh.vertex_count(), 0), used(mesh.vertex_count(), 0);
    for (uint32_t v : mesh.tets) used[v] = 1;
    for (const auto& f : border_triangles(mesh))
      for (uint32_t v : f) on_border[v] = 1;
    const double share = double(std::count(on_border.begin(), on_border.end(), 1)) / double(std::max<size_t>(1, std::count(used.begin(), used.end(), 1)));
    if (share > kAutoSampleMaxBorderShare)
      return choose(SimplifyMethod::kQem, "most vertices on the border (" + std::to_string(int(100 * share)) + "%): the sampler's border phase decides");
  }
  if (!border_self_intersections(mesh, 1).pairs.empty()) return choose(SimplifyMethod::kQem, "the border crosses itself: TetGen cannot mesh it");
  return choose(SimplifyMethod::kSample, "the sampler: measured faster at comparable error on such meshes");
}

SimplifyReport simplify_sampled(storage::TetMesh& mesh, const SimplifyOptions& options, const std::vector<uint8_t>& locked) {
  const auto started = std::chrono::steady_clock::now();
  const size_t nv = mesh.vertex_count();
  check_sample_options(options, locked, nv);
  SimplifyReport report;
  report.tets_before = mesh.tet_count();
  report.vertices_before = nv;
  size_t channels = 0;
  const std::vector<float> values = normalised_channels(mesh, options, &channels);

  std::vector<Point3> positions(nv);
  for (size_t v = 0; v < nv; ++v) positions[v] = {mesh.x[v], mesh.y[v], mesh.z[v]};
  const storage::Bounds bounds = options.frame ? *options.frame : storage::compute_bounds(mesh);
  double diagonal = 0, extent = 0;
  for (int k = 0; k < 3; ++k) {
    const double side = bounds.max[k] - bounds.min[k];
    diagonal += side * side;
    extent = std::max(extent, side);
  }
  diagonal = std::sqrt(diagonal);

  Lap lap;
  // 1. the border, simplified without self-intersections (§4.2.1)
  const std::vector<std::array<uint32_t, 3>> border = border_triangles(mesh);
  report.border_before = border.size();
  const detail::BorderField field{values.data(), channels, kBorderFieldWeight * diagonal, sq(kFreeBorderCost * diagonal)};
  const detail::BorderSimplifyResult simplified = simplify_mesh_border(mesh, options, locked, positions, border, field, diagonal, report);
  lap(report.border_seconds);

  // 2. the interior points: used, not on the original border, not locked
  const std::vector<uint32_t> interior = interior_points(mesh, border, locked);
  // the tetrahedralization's points: the simplified border's vertices, then the samples
  TetPoints tet_points = border_points_and_facets(simplified.triangles, nv);

  // A border that crosses itself (two faces the simplifier never touched, e.g. locked ones
  // from neighbouring segments) makes TetGen fail, and TetGen 1.5 then crashes while freeing
  // its memory (found on the 5M blade): such a mesh goes to the quadric simplifier instead.
  if (border_crosses_itself(positions, tet_points)) return fall_back_to_qem(mesh, options, locked, report);

  PointSampler sampler(positions, values, channels, extent);
  // 3. sample and tetrahedralize (§4.2.2-4.2.3); once more when the target was missed by far
  std::vector<uint32_t> samples;
  Tetrahedralization tetrahedra;
  if (!sample_and_tetrahedralize(sampler, interior, positions, tet_points, options, locked, lap, report, samples, tetrahedra))
    return fall_back_to_qem(mesh, options, locked, report);
  report.samples = samples.size();

  // 4. the output mesh: the points the tets use (input order), then the Steiner points
  const size_t inputs = tet_points.border_points + samples.size();
  for (uint32_t s : samples) tet_points.input_vertex.push_back(s);
  storage::TetMesh out = assemble_output(mesh, tet_points.input_vertex, inputs, tetrahedra, report);
  // TetGen fills a cavity that the border encloses (no hole point marks it): the output's
  // border then lacks those facets. The mesh is left to the quadric simplifier instead.
  if (border_triangles(out).size() != tet_points.facets.size()) return fall_back_to_qem(mesh, options, locked, report);
  lap(report.output_seconds);
  if (options.fit_values) {
    std::vector<uint8_t> fixed(out.vertex_count(), 0);
    for (size_t o = 0; o < fixed.size(); ++o)
      fixed[o] = report.source_vertex[o] != kSteiner && !locked.empty() && locked[report.source_vertex[o]];
    detail::fit_values(mesh, out, report.source_vertex, fixed);
    lap(report.fit_seconds);
  }
  mesh = std::move(out);
  report.tets_after = mesh.tet_count();
  report.vertices_after = mesh.vertex_count();
  report.runs = report.tetrahedralizations;
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  return report;
}

}  // namespace tetrascope::lod
