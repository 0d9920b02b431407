// The runtime cut of dissertation §6.3.4: refine and coarsen queues ordered by the
// histogram error weighted with the transfer function and the segment's share of the view,
// per tet the step adds or frees, under a tet budget.
#include "tetrascope/lod/cut/cut.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <queue>
#include <unordered_map>

#include "tetrascope/core/tet_topology.h"
#include "tetrascope/core/vec3.h"

namespace tetrascope::lod {

using dag::kRoot;

Cut::Cut(const Dag& dag) : dag_(dag) {
  const uint32_t n = dag.node_count();
  refined_.assign(n, 0);
  refined_children_.assign(n, 0);
  unrefined_parents_.assign(n, 0);
  gain_.assign(n, 0);
  flipped_.assign(dag.patch_count(), 0);
  was_active_.assign(dag.patch_count(), 0);
  for (uint32_t v = 0; v < n; ++v) {
    int64_t children = 0;
    for (const auto& p : dag.child_patches(v)) children += p.tet_count;
    gain_[v] = children - dag.node(v).tet_count;
    for (uint32_t p : dag.parent_patches(v))
      if (dag.patch(p).ceiling != kRoot) ++unrefined_parents_[v];
  }
  double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
  for (uint32_t p = 0; p < dag.root_patch_count(); ++p) {
    tets_ += dag.patch(p).tet_count;
    const float* box = dag.node(dag.patch(p).floor).bounds;
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min<double>(lo[k], box[k]);
      hi[k] = std::max<double>(hi[k], box[k + 3]);
    }
  }
  if (dag.root_patch_count() > 0) scene_diagonal_ = std::sqrt(std::pow(hi[0] - lo[0], 2) + std::pow(hi[1] - lo[1], 2) + std::pow(hi[2] - lo[2], 2));
}

bool Cut::displayed(uint32_t node) const { return !refined_[node] && unrefined_parents_[node] == 0; }

bool Cut::shown(uint32_t node) const {
  if (refined_[node]) return false;
  if (unrefined_parents_[node] == 0) return true;
  for (uint32_t p : dag_.parent_patches(node))
    if (active(p)) return true;
  return false;
}

bool Cut::active(uint32_t patch) const {
  const dag::Patch& p = dag_.patch(patch);
  return (p.ceiling == kRoot || refined_[p.ceiling]) && !refined_[p.floor];
}

std::vector<uint32_t> Cut::active_patches() const {
  std::vector<uint32_t> out;
  for (uint32_t p = 0; p < dag_.patch_count(); ++p)
    if (active(p)) out.push_back(p);
  return out;
}

void Cut::note(uint32_t patch) {
  if (!flipped_[patch]) {
    flipped_[patch] = 1;
    was_active_[patch] = !active(patch);  // called after the change
    flips_.push_back(patch);
  }
}

void Cut::apply_refine(uint32_t node, CutChanges* changes) {
  drop_variant(node);  // its tets give way to its children's
  refined_[node] = 1;
  tets_ = static_cast<uint64_t>(static_cast<int64_t>(tets_) + gain_[node]);
  for (uint32_t p : dag_.parent_patches(node)) {
    note(p);
    if (dag_.patch(p).ceiling != kRoot) ++refined_children_[dag_.patch(p).ceiling];
  }
  const dag::Node& n = dag_.node(node);
  for (uint32_t p = n.first_child; p < n.first_child + n.child_count; ++p) {
    note(p);
    --unrefined_parents_[dag_.patch(p).floor];
  }
  if (changes) ++changes->refinements;
}

void Cut::apply_coarsen(uint32_t node, CutChanges* changes) {
  if (variants_)  // its children stop being shown whole
    for (const auto& c : dag_.child_patches(node)) drop_variant(c.floor);
  refined_[node] = 0;
  tets_ = static_cast<uint64_t>(static_cast<int64_t>(tets_) - gain_[node]);
  for (uint32_t p : dag_.parent_patches(node)) {
    note(p);
    if (dag_.patch(p).ceiling != kRoot) --refined_children_[dag_.patch(p).ceiling];
  }
  const dag::Node& n = dag_.node(node);
  for (uint32_t p = n.first_child; p < n.first_child + n.child_count; ++p) {
    note(p);
    ++unrefined_parents_[dag_.patch(p).floor];
  }
  if (changes) ++changes->coarsenings;
}

// The unrefined ancestors a refinement of `node` needs, coarsest first, node last.
namespace {
// the smallest and largest n.x - d over a box's corners
std::pair<double, double> side_range(const view::Plane& plane, const float box[6]) {
  double lo = -plane.offset, hi = -plane.offset;
  for (int k = 0; k < 3; ++k) {
    const double a = plane.normal[k] * box[k], b = plane.normal[k] * box[k + 3];
    lo += std::min(a, b);
    hi += std::max(a, b);
  }
  return {lo, hi};
}
}  // namespace

bool clipped_away(std::span<const view::Plane> clip, const float box[6]) {
  for (const view::Plane& plane : clip)
    if (side_range(plane, box).first > 0) return true;
  return false;
}

bool crosses(const view::Plane& plane, const float box[6]) {
  const auto [lo, hi] = side_range(plane, box);
  return lo <= 0 && hi >= 0;
}

double Cut::slice_weight(uint32_t node, uint32_t channel) {
  if (channel >= dag_.channel_count()) return 1.0 / (1 + dag_.node(node).level);
  if (slice_weight_.size() != dag_.node_count() || slice_weight_channel_ != channel) {
    slice_weight_.assign(dag_.node_count(), -1);
    slice_weight_channel_ = channel;
  }
  if (slice_weight_[node] < 0) {
    double sum = 0;
    for (float h : dag_.field_histogram(node, channel)) sum += h;
    slice_weight_[node] = sum;
  }
  return slice_weight_[node];
}

namespace {
using view::ViewFrame;

// The share of the view that a unit of error mass (error × volume, in units of the scene's
// size) at p covers once integrated along the rays through it: a cross-section at depth z
// spans 1/z² of the view's area at unit depth (orthographic: 1 over the view's area). Whole
// inside the view, fading to 0 at twice its half-extent (the mass is spread around its
// centroid), 0 behind the eye; z is taken at least `near` (the mass around the eye does not
// fill more than the view).
double mass_share(const ViewFrame& frame, const Vec3& p, double near) {
  double z = frame.depth(p);
  if (!frame.ortho && z <= 0) return 0.0;
  z = std::max(z, near);
  const auto xy = frame.ndc(p, z);
  const double outside = std::max(std::fabs(xy[0]), std::fabs(xy[1]));
  const double fade = std::clamp(2.0 - outside, 0.0, 1.0);
  const double area = 4 * frame.half_w() * frame.half_h();
  return fade / (area * (frame.ortho ? 1.0 : z * z));
}

template <class Refined>
std::vector<uint32_t> needed_refinements(const Dag& dag, uint32_t node, Refined&& refined) {
  std::vector<uint32_t> need{node}, stack{node};
  std::unordered_map<uint32_t, bool> seen{{node, true}};
  while (!stack.empty()) {
    uint32_t v = stack.back();
    stack.pop_back();
    for (uint32_t p : dag.parent_patches(v)) {
      const uint32_t c = dag.patch(p).ceiling;
      if (c == kRoot || refined(c) || seen.count(c)) continue;
      seen[c] = true;
      need.push_back(c);
      stack.push_back(c);
    }
  }
  // parents have higher levels: refine the highest level first
  std::stable_sort(need.begin(), need.end(), [&](uint32_t a, uint32_t b) { return dag.node(a).level > dag.node(b).level; });
  return need;
}
}  // namespace

int64_t Cut::refinement_cost(uint32_t node) const {
  if (refined_[node] || dag_.node(node).child_count == 0) return 0;
  int64_t cost = 0;
  for (uint32_t v : needed_refinements(dag_, node, [&](uint32_t c) { return refined_[c] != 0; })) cost += gain_[v] - variant_extra(v);
  return cost;
}

bool Cut::refine(uint32_t node, uint64_t budget, CutChanges* changes) {
  if (refined_[node] || dag_.node(node).child_count == 0) return false;
  auto need = needed_refinements(dag_, node, [&](uint32_t c) { return refined_[c] != 0; });
  int64_t cost = 0;
  for (uint32_t v : need) cost += gain_[v] - variant_extra(v);
  if (budget && static_cast<int64_t>(tets_ + variant_tets_) + cost > static_cast<int64_t>(budget)) return false;
  for (uint32_t v : need) apply_refine(v, changes);
  if (changes) changes->forced_refinements += static_cast<uint32_t>(need.size() - 1);
  return true;
}

bool Cut::coarsen(uint32_t node, CutChanges* changes) {
  if (!can_coarsen(node)) return false;
  apply_coarsen(node, changes);
  return true;
}

void Cut::refine_all() {
  // coarsest first: every parent is refined before its children
  std::vector<uint32_t> order(dag_.node_count());
  for (uint32_t v = 0; v < order.size(); ++v) order[v] = v;
  std::stable_sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) { return dag_.node(a).level > dag_.node(b).level; });
  for (uint32_t v : order)
    if (!refined_[v] && dag_.node(v).child_count > 0) apply_refine(v, nullptr);
  for (uint32_t p : flips_) flipped_[p] = 0;
  flips_.clear();
}

std::vector<uint32_t> Cut::resident_segments() const {
  std::vector<uint8_t> keep(dag_.node_count(), 0);
  for (uint32_t p = 0; p < dag_.patch_count(); ++p) {
    if (!active(p)) continue;
    const dag::Patch& q = dag_.patch(p);
    keep[q.floor] = 1;
    if (q.ceiling != kRoot) keep[q.ceiling] = 1;
    for (const auto& c : dag_.child_patches(q.floor)) keep[c.floor] = 1;
  }
  std::vector<uint32_t> out;
  for (uint32_t v = 0; v < keep.size(); ++v)
    if (keep[v]) out.push_back(v);
  return out;
}

CutChanges Cut::update(const CutCriteria& criteria, uint64_t budget) {
  CutChanges changes;
  const std::vector<uint8_t> variants_before = variant_;
  variant_.assign(variants_ ? dag_.node_count() : 0, 0);  // the refinements below see the segments' own tets
  variant_tets_ = 0;
  update_weights(criteria);
  const std::vector<double> e = segment_errors(criteria);
  coarsen_to_budget(e, budget, changes);
  refine_within_budget(e, budget, changes);
  trade_refinements(e, budget, changes);
  if (variants_) fill_variants(e, budget);
  changes.variants_changed = variant_ != variants_before;
  collect_changes(e, budget, changes);
  return changes;
}

// Σ H·C per node, cached while the transfer function and isovalues stay the same.
void Cut::update_weights(const CutCriteria& criteria) {
  const uint32_t n = dag_.node_count();
  if (weight_.size() != n || weight_channel_ != criteria.channel || weight_opacity_ != criteria.opacity || weight_isovalues_ != criteria.isovalues) {
    weight_.assign(n, 0);
    const uint32_t bins = dag_.bins();
    if (criteria.channel < dag_.channel_count()) {
      for (uint32_t v = 0; v < n; ++v) {
        double sum = 0;
        if (!criteria.isovalues.empty()) {
          // The isosurface crosses the segment where its values straddle the isovalue: the
          // error that matters is that of the values nearest it on either side (a histogram
          // of a coarse segment has few filled bins, so the isovalue's own bin is often empty).
          auto h = dag_.spatial_histogram(v, criteria.channel);
          for (double iso : criteria.isovalues) {
            const int bin = std::clamp(static_cast<int>(iso * bins), 0, static_cast<int>(bins) - 1);
            int below = bin, above = bin;
            while (below >= 0 && h[below] <= 0) --below;
            while (above < static_cast<int>(bins) && h[above] <= 0) ++above;
            if (below < 0 || above >= static_cast<int>(bins)) continue;  // all on one side: the surface misses it
            for (int b = below; b <= above; ++b) sum = std::max<double>(sum, h[b]);
          }
        } else {
          auto h = dag_.field_histogram(v, criteria.channel);
          for (uint32_t b = 0; b < bins; ++b) sum += double(h[b]) * (criteria.opacity.size() == bins ? criteria.opacity[b] : 1.0f);
        }
        weight_[v] = sum;
      }
    } else {
      for (uint32_t v = 0; v < n; ++v) weight_[v] = 1.0 / (1 + dag_.node(v).level) + 1e-9 * dag_.node(v).tet_count;  // no attributes: by level
    }
    weight_channel_ = criteria.channel;
    weight_opacity_ = criteria.opacity;
    weight_isovalues_ = criteria.isovalues;
  }
}

// The error each segment shows in the view (0 outside the frustum or clipped away).
std::vector<double> Cut::segment_errors(const CutCriteria& criteria) {
  const uint32_t n = dag_.node_count();
  const ViewFrame frame = criteria.camera ? ViewFrame::of(*criteria.camera) : ViewFrame{};
  const bool framed = criteria.camera && frame.valid;
  // Volume rendering on a store with error masses: the error each segment leaves on screen,
  // Σ_n O(n)·M(n)·S(c_n): the opacity of value slot n, the error mass of the slot and the
  // share of the view its centroid's depth gives a unit of it. Otherwise (isosurfaces, stores
  // of format 1) the largest error per slot weighted with the box's share of the view.
  const bool by_mass = dag_.has_mass() && criteria.isovalues.empty() && criteria.channel < dag_.channel_count();
  const double scene = scene_diagonal_;
  // the mass shows through slabs of the unit distance: thinner ones than the default show more
  const double slab = criteria.unit_distance > 0 ? 0.01 * scene / criteria.unit_distance : 1.0;
  auto mass_error = [&](uint32_t v) {
    const auto mass = dag_.mass_histogram(v, criteria.channel);
    const auto cx = dag_.mass_centroid(v, criteria.channel, 0), cy = dag_.mass_centroid(v, criteria.channel, 1), cz = dag_.mass_centroid(v, criteria.channel, 2);
    const bool weighted = criteria.opacity.size() == mass.size();
    double sum = 0;
    for (size_t b = 0; b < mass.size(); ++b) {
      const double o = weighted ? criteria.opacity[b] : 1.0;
      if (!(mass[b] > 0) || !(o > 0)) continue;
      sum += o * mass[b] * (framed ? mass_share(frame, Vec3{cx[b], cy[b], cz[b]}, 0.01 * scene) * scene * scene : 1.0);
    }
    const double out = sum * slab;
    return std::isfinite(out) ? out : 0.0;  // (masses near the float limit in a damaged file)
  };
  auto error = [&](uint32_t v) {
    const float* box = dag_.node(v).bounds;
    if (criteria.frustum && !criteria.frustum->intersects(box)) return 0.0;
    if (clipped_away(criteria.clip, box)) return 0.0;
    auto share = [&] { return framed ? frame.box_share(box) : 1.0; };  // 1 without a camera
    double out = by_mass ? mass_error(v) : weight_[v] * share();
    for (const view::Plane& slice : criteria.slices)
      if (crosses(slice, box)) out = std::max(out, kSliceWeight * slice_weight(v, criteria.channel) * share());
    return out;
  };
  std::vector<double> e(n);
  for (uint32_t v = 0; v < n; ++v) e[v] = error(v);
  return e;
}

// error removed per tet added (forced refinements included), and error added per tet freed
double Cut::refine_priority(const std::vector<double>& e, uint32_t v) const {
  return e[v] * variant_share(v) / double(std::max<int64_t>(1, refinement_cost(v)));
}
double Cut::coarsen_priority(const std::vector<double>& e, uint32_t v) const { return e[v] / double(std::max<int64_t>(1, gain_[v])); }

// 1. coarsen: everything invisible, then the cheapest until the budget holds
void Cut::coarsen_to_budget(const std::vector<double>& e, uint64_t budget, CutChanges& changes) {
  const uint32_t n = dag_.node_count();
  using Item = std::pair<double, uint32_t>;
  std::priority_queue<Item, std::vector<Item>, std::greater<Item>> coarse;
  for (uint32_t v = 0; v < n; ++v)
    if (can_coarsen(v)) coarse.push({coarsen_priority(e, v), v});
  while (!coarse.empty()) {
    auto [err, v] = coarse.top();
    if (!(err <= 0 || tets_ > budget)) break;
    coarse.pop();
    if (!can_coarsen(v)) continue;
    apply_coarsen(v, &changes);
    for (uint32_t p : dag_.parent_patches(v)) {
      const uint32_t c = dag_.patch(p).ceiling;
      if (c != kRoot && can_coarsen(c)) coarse.push({coarsen_priority(e, c), c});
    }
  }
}

// 2. refine the largest errors while they fit
void Cut::refine_within_budget(const std::vector<double>& e, uint64_t budget, CutChanges& changes) {
  const uint32_t n = dag_.node_count();
  using Item = std::pair<double, uint32_t>;
  // A segment is queued once shown whole or once next to a refined one (its forced parents
  // make it dearer, not impossible); a refinement only lowers the cost of others, so a
  // popped priority that grew is pushed back with its new value.
  std::priority_queue<Item> fine;
  std::vector<uint8_t> queued(n, 0);
  auto offer = [&](uint32_t v) {
    if (!refined_[v] && dag_.node(v).child_count > 0 && e[v] > 0) {
      fine.push({refine_priority(e, v), v});
      queued[v] = 1;
    }
  };
  // every segment shown, in whole or in part (a patch of it active): one shown in part stays
  // shown in part across updates, so a cut refined in steps would otherwise never queue it
  // again once a budget had not fit it (Cut.ACutRefinedInStepsReachesWhatOneUpdateReaches)
  for (uint32_t v = 0; v < n; ++v)
    if (shown(v)) offer(v);
  uint32_t misses = 0;
  while (!fine.empty() && misses < 16) {
    auto [priority, v] = fine.top();
    fine.pop();
    if (refined_[v]) continue;
    const double now = refine_priority(e, v);
    if (now > priority * (1 + 1e-12) && !fine.empty() && now < fine.top().first) {
      fine.push({now, v});
      continue;
    }
    if (!refine(v, budget, &changes)) {
      changes.budget_limited = true;
      ++misses;
      continue;
    }
    for (const auto& c : dag_.child_patches(v)) offer(c.floor);
  }
}

// 3. trade: coarsen the cheapest refined segment when that lets a dearer one refine
void Cut::trade_refinements(const std::vector<double>& e, uint64_t budget, CutChanges& changes) {
  const uint32_t n = dag_.node_count();
  for (int round = 0; round < 32; ++round) {
    double best = 0;
    uint32_t want = dag::kRoot;
    for (uint32_t v = 0; v < n; ++v)
      if (displayed(v) && dag_.node(v).child_count > 0 && e[v] > 0 && refine_priority(e, v) > best) {
        best = refine_priority(e, v);
        want = v;
      }
    if (want == dag::kRoot) break;
    const int64_t cost = refinement_cost(want);
    if (static_cast<int64_t>(tets_ + variant_tets_) + cost <= static_cast<int64_t>(budget)) {
      refine(want, budget, &changes);
      continue;
    }
    double cheapest = best;
    uint32_t give = dag::kRoot;
    for (uint32_t v = 0; v < n; ++v) {
      if (!can_coarsen(v) || gain_[v] <= 0 || !(coarsen_priority(e, v) < cheapest)) continue;
      bool parent = false;  // giving up a parent of the wanted segment gains nothing
      for (uint32_t p : dag_.parent_patches(want)) parent |= dag_.patch(p).ceiling == v;
      if (parent) continue;
      cheapest = coarsen_priority(e, v);
      give = v;
    }
    if (give == dag::kRoot || static_cast<int64_t>(tets_ + variant_tets_) - gain_[give] + cost > static_cast<int64_t>(budget)) break;
    apply_coarsen(give, &changes);
    if (!refine(want, budget, &changes)) {  // the coarsening made the wanted one dearer: undo
      apply_refine(give, &changes);
      break;
    }
  }
}

// What changed, as patches, the tets and the estimated error the cut leaves.
void Cut::collect_changes(const std::vector<double>& e, uint64_t budget, CutChanges& changes) {
  // what changed, as patches
  for (uint32_t p : flips_) {
    const bool now = active(p);
    if (now != static_cast<bool>(was_active_[p])) (now ? changes.added : changes.removed).push_back(p);
    flipped_[p] = 0;
  }
  flips_.clear();
  std::sort(changes.added.begin(), changes.added.end());
  std::sort(changes.removed.begin(), changes.removed.end());
  changes.tets = tets_ + variant_tets_;
  changes.over_budget = tets_ > budget;
  // each shown patch carries its share of its segment's error: a segment shown in part (its
  // other parents unrefined) counts in part, so refining never adds a whole child's error
  for (uint32_t p = 0; p < dag_.patch_count(); ++p) {
    if (!active(p)) continue;
    const dag::Patch& q = dag_.patch(p);
    const uint32_t tets = dag_.node(q.floor).tet_count;
    if (tets > 0) changes.estimated_error += e[q.floor] * double(q.tet_count) / double(tets) * variant_share(q.floor);
  }
}

// Step 4 of update(), with variants: the budget refinement could not use. A segment's error is
// taken to fall as 1/tets from its own tets (t0) to a variant's (t): t0/t of it remains. The
// steps from one variant to the next finer (variant_priority) that remove the most error a tet
// are taken while they fit; one that does not fit ends that segment's steps.
void Cut::fill_variants(const std::vector<double>& e, uint64_t budget) {
  const uint32_t n = dag_.node_count();
  using Item = std::pair<double, uint32_t>;
  std::priority_queue<Item> queue;
  for (uint32_t v = 0; v < n; ++v)
    if (displayed(v) && e[v] > 0 && variant_[v] < variant_count(v)) queue.push({variant_priority(e[v], v, variant_[v]), v});
  int64_t left = static_cast<int64_t>(budget) - static_cast<int64_t>(tets_ + variant_tets_);
  while (!queue.empty() && left > 0) {
    const uint32_t v = queue.top().second;
    queue.pop();
    const uint32_t j = variant_[v];
    const int64_t step = static_cast<int64_t>(variant_tets(v, j + 1) - variant_tets(v, j));
    if (step > left) continue;
    variant_[v] = static_cast<uint8_t>(j + 1);
    left -= step;
    variant_tets_ = static_cast<uint64_t>(static_cast<int64_t>(variant_tets_) + step);
    if (j + 1 < variant_count(v)) queue.push({variant_priority(e[v], v, j + 1), v});
  }
}

uint32_t Cut::variant_count(uint32_t node) const {
  return variants_ && dag_.node(node).tet_count > 0 ? variants_->count(node) : 0;
}

uint64_t Cut::variant_tets(uint32_t node, uint32_t j) const { return j == 0 ? dag_.node(node).tet_count : variants_->tets(node, j - 1); }

int64_t Cut::variant_extra(uint32_t node) const {
  const uint32_t j = variant_of(node);
  return j == 0 ? 0 : static_cast<int64_t>(variant_tets(node, j)) - static_cast<int64_t>(dag_.node(node).tet_count);
}

void Cut::drop_variant(uint32_t node) {
  if (variant_of(node) == 0) return;
  variant_tets_ = static_cast<uint64_t>(static_cast<int64_t>(variant_tets_) - variant_extra(node));
  variant_[node] = 0;
}

// The step from variant j to j + 1: a segment's error taken to fall as 1/tets, e·t0·(1/t_j -
// 1/t_{j+1}) removed for t_{j+1} - t_j tets.
double Cut::variant_priority(double e, uint32_t node, uint32_t j) const {
  const double t0 = double(variant_tets(node, 0)), a = double(variant_tets(node, j)), b = double(variant_tets(node, j + 1));
  return e * t0 * (1 / a - 1 / b) / std::max(1.0, b - a);
}

double Cut::variant_share(uint32_t node) const {
  const uint32_t j = variant_of(node);
  if (j == 0) return 1.0;
  return double(variant_tets(node, 0)) / double(variant_tets(node, j));
}

size_t ResidentSegments::update(const Cut& cut, storage::SegmentCache& cache) {
  const std::vector<uint32_t> want = cut.resident_segments();
  std::unordered_map<uint32_t, std::shared_ptr<const storage::MappedSegment>> next;
  size_t added = 0;
  for (uint32_t s : want) {
    auto it = pinned_.find(s);
    if (it != pinned_.end()) {
      next.emplace(s, std::move(it->second));
    } else {
      next.emplace(s, cache.get(s));
      ++added;
    }
  }
  pinned_.swap(next);
  return added;
}

void set_view(CutCriteria& criteria, const Camera& camera, double far_plane) {
  criteria.frustum = view_frustum(camera, 0, far_plane);
  criteria.camera = camera;
}

CutCriteria criteria_for(const storage::Store& store, const Dag& dag, const TransferFunction& tf, std::span<const double> isovalues) {
  CutCriteria c;
  const auto& attributes = store.manifest().attributes;
  uint32_t channel = 0;
  for (; channel < attributes.size(); ++channel)
    if (attributes[channel].name == tf.attribute) break;
  if (channel == attributes.size()) {
    if (!tf.attribute.empty()) throw std::invalid_argument("transfer function: no attribute '" + tf.attribute + "' in the store");
    channel = 0;
  }
  c.channel = channel;
  if (attributes.empty()) return c;
  // one component of a vector: the channel's histograms are of the magnitude, which says
  // nothing of where a component's value is seen; the cut goes by error and view alone
  if (tf.component != view::kMagnitude && attributes[channel].components > 1) return c;
  const double lo = attributes[channel].components == 1 ? attributes[channel].min : 0, hi = attributes[channel].max;
  for (double v : isovalues) c.isovalues.push_back((v - lo) / (hi > lo ? hi - lo : 1));
  if (channel >= dag.channel_count()) return c;
  TransferFunction f = tf;
  if (!f.range) f.range = std::array<double, 2>{lo, hi > lo ? hi : lo + 1};
  c.opacity.resize(dag.bins());
  for (uint32_t b = 0; b < dag.bins(); ++b) {
    const double value = lo + (b + 0.5) / dag.bins() * (hi - lo);
    c.opacity[b] = static_cast<float>(f.alpha(value));
  }
  return c;
}

namespace {
// What a cut's mesh is assembled from: the active patches, less those of segments wholly
// clipped away and those of segments shown as a variant (listed apart, in order).
void choose_patches(const Cut& cut, std::span<const view::Plane> clip, CutMesh& out) {
  const Dag& dag = cut.dag();
  out.patches = cut.active_patches();
  if (!clip.empty()) std::erase_if(out.patches, [&](uint32_t p) { return clipped_away(clip, dag.node(dag.patch(p).floor).bounds); });
  if (!cut.variants()) return;
  std::vector<uint32_t>& shown_variants = out.variant_segments;
  for (uint32_t p : out.patches) {
    const uint32_t f = dag.patch(p).floor;
    if (cut.variant_of(f) != 0) shown_variants.push_back(f);
  }
  std::sort(shown_variants.begin(), shown_variants.end());
  shown_variants.erase(std::unique(shown_variants.begin(), shown_variants.end()), shown_variants.end());
  std::erase_if(out.patches, [&](uint32_t p) { return cut.variant_of(dag.patch(p).floor) != 0; });
}
}  // namespace

CutMesh assemble_cut(const storage::Store& store, storage::SegmentCache& cache, const Cut& cut, bool adjacency, std::span<const view::Plane> clip,
                     const std::function<bool()>& should_stop) {
  using storage::store::kMeshBoundary;
  using storage::store::kSegmentBorder;
  const Dag& dag = cut.dag();
  CutMesh out;
  choose_patches(cut, clip, out);
  const std::vector<uint32_t>& shown_variants = out.variant_segments;  // their patches left out
  const auto& attributes = store.manifest().attributes;
  for (const auto& a : attributes) out.mesh.attributes.push_back({{a.name, a.components, a.kind, a.positive_semidefinite, a.derived_from}, {}});
  std::unordered_map<uint32_t, uint32_t> vertex_of;
  // A vertex appended: its position, global id and every attribute's components, value(offset,
  // components, q) giving component q of the attribute `offset` floats into a vertex's.
  auto append_vertex = [&](uint32_t g, float x, float y, float z, auto&& value) {
    out.mesh.x.push_back(x);
    out.mesh.y.push_back(y);
    out.mesh.z.push_back(z);
    out.global_ids.push_back(g);
    size_t offset = 0;
    for (size_t a = 0; a < attributes.size(); ++a) {
      const uint32_t c = attributes[a].components;
      for (uint32_t q = 0; q < c; ++q) out.mesh.attributes[a].values.push_back(value(offset, c, q));
      offset += c;
    }
  };
  std::vector<OpenFace> open;  // faces glued to another patch's or segment's
  for (uint32_t p : out.patches) {
    if (should_stop && should_stop()) {
      out.interrupted = true;
      return out;
    }
    const dag::Patch& patch = dag.patch(p);
    auto segment = cache.get(patch.floor);
    const storage::SegmentView& s = segment->view();
    const uint32_t first = static_cast<uint32_t>(out.mesh.tet_count());
    out.patch_first_tet.push_back(first);
    std::vector<uint32_t> local(s.vertex_count, 0xFFFFFFFFu);
    for (uint32_t t = patch.tet_begin; t < patch.tet_begin + patch.tet_count; ++t) {
      for (int k = 0; k < 4; ++k) {
        const uint32_t l = s.tets[4 * size_t{t} + k];
        if (local[l] == 0xFFFFFFFFu) {
          const uint32_t g = s.global_ids[l];
          auto [it, inserted] = vertex_of.try_emplace(g, static_cast<uint32_t>(out.mesh.x.size()));
          if (inserted)  // a segment's values are attribute-major
            append_vertex(g, s.x[l], s.y[l], s.z[l], [&](size_t offset, uint32_t c, uint32_t q) { return s.attributes[size_t{s.vertex_count} * offset + size_t{l} * c + q]; });
          local[l] = it->second;
        }
        out.mesh.tets.push_back(local[l]);
      }
    }
    if (!adjacency) continue;
    out.opposites.resize(out.mesh.tets.size(), kMeshBoundary);
    for (uint32_t t = patch.tet_begin; t < patch.tet_begin + patch.tet_count; ++t) {
      for (uint32_t f = 0; f < 4; ++f) {
        const uint32_t o = s.opposites[4 * size_t{t} + f];
        const uint32_t here = (first + t - patch.tet_begin) * 4 + f;
        if (o != kMeshBoundary && o != kSegmentBorder && o / 4 >= patch.tet_begin && o / 4 < patch.tet_begin + patch.tet_count) {
          out.opposites[here] = (first + o / 4 - patch.tet_begin) * 4 + o % 4;
        } else if (o != kMeshBoundary) {  // another patch's face, or another segment's
          FaceVertices face = tet_face(out.mesh.tets, here / 4, int(f));
          for (uint32_t& v : face) v = out.global_ids[v];
          open.push_back({face_key(face), p, here});
        }
      }
    }
  }
  for (uint32_t v : shown_variants) {
    if (should_stop && should_stop()) {
      out.interrupted = true;
      return out;
    }
    const VariantView m = cut.variants()->view(v, cut.variant_of(v) - 1);
    std::vector<uint32_t> local(m.vertex_count);
    for (size_t l = 0; l < m.vertex_count; ++l) {
      const uint32_t g = m.global[l];
      if (g != kNoGlobal) {
        auto [it, inserted] = vertex_of.try_emplace(g, static_cast<uint32_t>(out.mesh.x.size()));
        local[l] = it->second;
        if (!inserted) continue;
      } else {
        local[l] = static_cast<uint32_t>(out.mesh.x.size());
      }
      // a variant's values are per vertex
      append_vertex(g, m.xyz[3 * l], m.xyz[3 * l + 1], m.xyz[3 * l + 2], [&](size_t offset, uint32_t, uint32_t q) { return m.values[l * cut.variants()->floats() + offset + q]; });
    }
    const uint32_t first = static_cast<uint32_t>(out.mesh.tet_count());
    for (uint32_t l : m.tets) out.mesh.tets.push_back(local[l]);
    if (!adjacency) continue;
    // its own faces paired among its tets; the rest glued to the neighbours' by global ids,
    // or the mesh boundary (a face with a moved vertex has no neighbour outside)
    out.opposites.resize(out.mesh.tets.size(), kMeshBoundary);
    const FacePairing pairs = pair_faces(m.tets);
    for (uint32_t f = 0; f < pairs.opposite.size(); ++f) {
      const uint32_t here = 4 * first + f;
      if (pairs.opposite[f] != kNoOppositeFace) {
        out.opposites[here] = 4 * first + pairs.opposite[f];
        continue;
      }
      FaceVertices face = tet_face(out.mesh.tets, here / 4, int(f % 4));
      bool named = true;
      for (uint32_t& id : face) named &= (id = out.global_ids[id]) != kNoGlobal;
      if (named) open.push_back({face_key(face), dag.patch_count() + v, here});
    }
  }
  if (adjacency) {
    pair_open_faces(open, [&](const OpenFace& a, const OpenFace& b) {
      out.opposites[a.face] = b.face;
      out.opposites[b.face] = a.face;
    });
  }
  return out;
}

}  // namespace tetrascope::lod
