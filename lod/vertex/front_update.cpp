// The vertex front's update (§5.2.3 ranking, §5.3.3 validity): from the base mesh, the
// vertices of the front split in the order of the image error a split removes per tet it adds.
// A split is valid at run time when every tet it changes or brings back stays positively
// oriented: the neighbours need not be as refined as they were when the simplifier collapsed
// the edge. Positively oriented images of a conforming input cover its domain once, so such a
// front conforms. Only a split that would invert a tet first splits the later collapses
// whose vertices that tet holds, and is tried again.
#include <algorithm>
#include <map>
#include <mutex>
#include <queue>

#include "tetrascope/lod/vertex/vertex_front.h"

namespace tetrascope::lod {
namespace {

constexpr uint32_t kNone = 0xFFFFFFFFu;
constexpr int kMostForced = 512;  // the deepest chain of splits one split may force
constexpr uint8_t kMostCollapsedAgain = 2;  // times a collapse is applied again in one update
constexpr double kOrderedShare = 0.25;       // of the budget split in the simplification's reverse order first

}  // namespace

// The index of a hierarchy that update()'s run-time front reads, built once and shared by
// every front of that hierarchy.
std::shared_ptr<const VertexFront::RunTimeIndex> VertexFront::run_time_index(const VertexHierarchy& h, const std::vector<uint32_t>& parent) {
  static std::mutex mutex;
  static std::map<const VertexHierarchy*, std::weak_ptr<const RunTimeIndex>> built;
  const std::lock_guard<std::mutex> lock(mutex);
  if (auto index = built[&h].lock()) return index;
  auto index = std::make_shared<RunTimeIndex>();
  RunTimeIndex& x = *index;
  std::vector<uint32_t>& leaf_pos = x.leaf_pos;
  std::vector<uint32_t>& leaf_lo = x.leaf_lo;
  std::vector<uint32_t>& leaf_hi = x.leaf_hi;
  std::vector<uint32_t>& root = x.root;
  std::vector<uint32_t>& meet_offsets = x.meet_offsets;
  std::vector<uint32_t>& meet_tets = x.meet_tets;
  std::vector<uint8_t>& meets = x.meets;
  std::vector<uint32_t>& base_head = x.base_head;
  std::vector<uint32_t>& base_next = x.base_next;
  auto below = [&](uint32_t vertex, uint32_t leaf) { return leaf_pos[leaf] >= leaf_lo[vertex] && leaf_pos[leaf] < leaf_hi[vertex]; };
  const uint32_t V = h.input_vertices, N = h.vertex_count(), C = h.collapse_count();
  // the forest in preorder: the leaves below a vertex are an interval of positions
  leaf_pos.assign(V, 0);
  leaf_lo.assign(N, 0);
  leaf_hi.assign(N, 0);
  root.assign(N, 0);
  for (uint32_t v = N; v-- > 0;) root[v] = parent[v] == kNoCollapse ? v : root[V + parent[v]];
  uint32_t position = 0;
  std::vector<std::pair<uint32_t, bool>> stack;
  for (uint32_t r = N; r-- > 0;) {
    if (parent[r] != kNoCollapse) continue;
    stack.assign(1, {r, false});
    while (!stack.empty()) {
      const auto [u, closing] = stack.back();
      stack.pop_back();
      if (closing) {
        leaf_hi[u] = position;
        continue;
      }
      leaf_lo[u] = position;
      if (u < V) {
        leaf_pos[u] = position++;
        leaf_hi[u] = position;
        continue;
      }
      stack.push_back({u, true});
      for (uint32_t c : h.nodes[u - V].child) stack.push_back({c, false});
    }
  }
  // per tet the collapses at which two of its corners meet (their lowest common ancestor)
  const size_t T = h.input_tets();
  meets.assign(T, 0);
  std::vector<uint32_t> found(6 * T, kNone);
  meet_offsets.assign(size_t{C} + 1, 0);
  for (size_t t = 0; t < T; ++t) {
    const uint32_t* s = &h.tets[4 * t];
    for (int a = 0; a < 4; ++a)
      for (int b = a + 1; b < 4; ++b) {
        if (root[s[a]] != root[s[b]]) continue;
        uint32_t u = s[a];
        while (!below(u, s[b])) u = V + parent[u];
        const uint32_t collapse = u - V;
        uint32_t* mine = &found[6 * t];
        if (std::find(mine, mine + meets[t], collapse) != mine + meets[t]) continue;
        mine[meets[t]++] = collapse;
        ++meet_offsets[collapse + 1];
      }
  }
  for (uint32_t i = 0; i < C; ++i) meet_offsets[i + 1] += meet_offsets[i];
  meet_tets.resize(meet_offsets[C]);
  std::vector<uint32_t> fill(meet_offsets.begin(), meet_offsets.end() - 1);
  for (size_t t = 0; t < T; ++t)
    for (uint32_t k = 0; k < meets[t]; ++k) meet_tets[fill[found[6 * t + k]]++] = static_cast<uint32_t>(t);
  // the base mesh's stars: the tets no collapse degenerates, at their corners' roots
  base_head.assign(N, kNone);
  base_next.assign(4 * T, kNone);
  for (size_t t = 0; t < T; ++t) {
    if (meets[t]) continue;
    for (uint32_t k = 0; k < 4; ++k) {
      const uint32_t e = static_cast<uint32_t>(4 * t + k), r = root[h.tets[e]];
      base_next[e] = base_head[r];
      base_head[r] = e;
    }
  }
  for (auto it = built.begin(); it != built.end();) it = it->second.expired() ? built.erase(it) : std::next(it);
  built[&h] = index;
  return index;
}

void VertexFront::reset_relaxed() {
  head_ = index_->base_head;
  next_ = index_->base_next;
  meets_left_ = index_->meets;
  rep_.assign(index_->root.begin(), index_->root.begin() + h_.input_vertices);
}

uint32_t VertexFront::front_vertex(uint32_t leaf) {
  const uint32_t V = h_.input_vertices;
  uint32_t u = rep_[leaf];
  while (parent_[u] != kNoCollapse && applied_[parent_[u]]) u = V + parent_[u];  // collapsed again since
  while (u >= V && !applied_[u - V]) {  // split since: down to the child that holds the leaf
    const auto& child = h_.nodes[u - V].child;
    u = below(child[0], leaf) ? child[0] : child[1];
  }
  rep_[leaf] = u;
  return u;
}

double VertexFront::image_volume(const std::array<uint32_t, 4>& image) const {
  const float* p[4];
  for (int k = 0; k < 4; ++k) p[k] = &h_.positions[3 * size_t{image[k]}];
  double e[3][3];
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) e[r][c] = double(p[r + 1][c]) - p[0][c];
  return e[0][0] * (e[1][1] * e[2][2] - e[1][2] * e[2][1]) - e[0][1] * (e[1][0] * e[2][2] - e[1][2] * e[2][0]) + e[0][2] * (e[1][0] * e[2][1] - e[1][1] * e[2][0]);
}

// Whether splitting collapse i (its vertex on the front) keeps every tet it changes or brings
// back positively oriented (an input tet of no volume excepted) and fits `budget`; revived_
// receives the tets it brings back.
VertexFront::Trial VertexFront::try_split(uint32_t i, uint64_t budget) {
  const uint32_t v = h_.input_vertices + i;
  const auto& child = h_.nodes[i].child;
  auto side = [&](uint32_t leaf) { return below(child[0], leaf) ? child[0] : child[1]; };
  auto valid = [&](uint32_t t, const std::array<uint32_t, 4>& image) {
    if (image_volume(image) > 0) return true;
    const uint32_t* s = &h_.tets[4 * size_t{t}];
    return !(image_volume({s[0], s[1], s[2], s[3]}) > 0);
  };
  std::array<uint32_t, 4> image;
  for (uint32_t e = head_[v]; e != kNone; e = next_[e]) {
    const uint32_t t = e / 4;
    for (uint32_t k = 0; k < 4; ++k) {
      const uint32_t leaf = h_.tets[4 * size_t{t} + k];
      image[k] = k == e % 4 ? side(leaf) : front_vertex(leaf);
    }
    if (!valid(t, image)) {
      inverted_ = image;
      return Trial::inverted;
    }
  }
  revived_.clear();
  for (uint32_t m = index_->meet_offsets[i]; m < index_->meet_offsets[i + 1]; ++m) {
    const uint32_t t = index_->meet_tets[m];
    if (meets_left_[t] != 1) continue;  // another collapse still degenerates it
    for (uint32_t k = 0; k < 4; ++k) {
      const uint32_t leaf = h_.tets[4 * size_t{t} + k];
      image[k] = below(v, leaf) ? side(leaf) : front_vertex(leaf);
    }
    if (!valid(t, image)) {
      inverted_ = image;
      return Trial::inverted;
    }
    revived_.push_back(t);
  }
  return tets_ + revived_.size() > budget ? Trial::over_budget : Trial::ok;
}

// Splits collapse i as try_split() found it (revived_ holds what it brings back).
void VertexFront::commit_split(uint32_t i) {
  const uint32_t v = h_.input_vertices + i;
  const auto& child = h_.nodes[i].child;
  applied_[i] = 0;
  for (uint32_t e = head_[v], after = 0; e != kNone; e = after) {
    after = next_[e];
    const uint32_t leaf = h_.tets[e], c = below(child[0], leaf) ? child[0] : child[1];
    rep_[leaf] = c;
    next_[e] = head_[c];
    head_[c] = e;
  }
  head_[v] = kNone;
  for (uint32_t m = index_->meet_offsets[i]; m < index_->meet_offsets[i + 1]; ++m) --meets_left_[index_->meet_tets[m]];
  for (uint32_t t : revived_)
    for (uint32_t k = 0; k < 4; ++k) {
      const uint32_t e = 4 * t + k, u = front_vertex(h_.tets[e]);
      next_[e] = head_[u];
      head_[u] = e;
    }
  tets_ += revived_.size();
  last_added_ = revived_.size();
  if (own_[i] <= 0) unseen_added_ += revived_.size();
  pending_.push_back(i);
}

// Splits collapse i: its ancestors first (its vertex must be on the front), and while a tet
// would invert, the later collapses whose vertices that tet holds first. False (and over_budget when
// the budget was the reason) when it cannot; splits it forced before failing stay. The
// collapses applied again for it split again afterwards, without applying others again.
bool VertexFront::split_relaxed(uint32_t i, uint64_t budget, int depth, bool& over_budget, bool may_collapse) {
  if (!applied_[i]) return true;
  if (depth > kMostForced) return false;
  const uint32_t up = parent_[h_.input_vertices + i];
  // its vertex on the front: the parent split (again, when a split it forced applied the parent again)
  auto on_front = [&] { return up == kNoCollapse || !applied_[up] || split_relaxed(up, budget, depth + 1, over_budget, may_collapse); };
  if (!on_front()) return false;
  Trial trial = try_split(i, budget);
  // A tet it would invert holds vertices of later collapses (neighbours coarser than when the
  // edge collapsed): those split first, as Predictive Tetra Mesh forces them (§5.2.3). Or it
  // holds vertices of earlier collapses split before it (neighbours finer than then): those
  // collapse again for the split and split again after it.
  std::vector<uint32_t> again;
  for (int round = 0; trial == Trial::inverted && round < kMostForced; ++round) {
    const std::array<uint32_t, 4> inverted = inverted_;
    bool changed = false;
    for (uint32_t u : inverted)
      if (u > h_.input_vertices + i && !changed) {
        if (!split_relaxed(u - h_.input_vertices, budget, depth + 1, over_budget, may_collapse)) break;
        changed = true;
      }
    for (uint32_t u : inverted) {
      const uint32_t up_u = parent_[u];
      if (changed || !may_collapse || up_u == kNoCollapse || up_u >= i || applied_[up_u]) continue;
      changed = collapse_again(up_u, again, 0, budget);
    }
    if (!changed) break;
    trial = on_front() ? try_split(i, budget) : Trial::inverted;
  }
  if (trial == Trial::over_budget) over_budget = true;
  if (trial != Trial::ok) {
    for (uint32_t j : again) split_relaxed(j, budget, depth + 1, over_budget, false);
    return false;
  }
  commit_split(i);
  const uint64_t added = last_added_;
  bool ignored = false;
  for (uint32_t j : again) split_relaxed(j, budget, depth + 1, ignored, false);
  last_added_ = added;  // the tets of this split, not of those split again after it
  return true;
}

// Applies collapse j again, and first those split below it, children before parents, each
// appended to `again`; false when one of them cannot be.
bool VertexFront::collapse_again(uint32_t j, std::vector<uint32_t>& again, int depth, uint64_t budget) {
  const uint32_t V = h_.input_vertices;
  if (depth > kMostForced || recollapsed_[j] >= kMostCollapsedAgain) return false;
  for (uint32_t c : h_.nodes[j].child)
    if (c >= V && !applied_[c - V] && !collapse_again(c - V, again, depth + 1, budget)) return false;
  // a tet the collapse would invert holds vertices of later collapses (neighbours coarser
  // than when it was made): those split first
  bool collapsed = collapse_relaxed(j);
  for (int round = 0; !collapsed && round < kMostForced; ++round) {
    bool split = false, over = false;
    for (uint32_t u : std::array<uint32_t, 4>(inverted_))
      if (!split && u > V + j && u >= V && applied_[u - V]) split = split_relaxed(u - V, budget, depth + 1, over, false);
    if (!split) break;
    collapsed = collapse_relaxed(j);
  }
  if (!collapsed) return false;
  ++recollapsed_[j];
  again.push_back(j);
  return true;
}

// Applies collapse j again when both its children are on the front and no tet it changes
// inverts: the tets with a corner below each child go, the others take its vertex.
bool VertexFront::collapse_relaxed(uint32_t j) {
  const uint32_t V = h_.input_vertices, u = V + j;
  const auto& child = h_.nodes[j].child;
  for (uint32_t c : child)
    if (c >= V && !applied_[c - V]) return false;  // refined further below
  std::array<uint32_t, 4> image;
  for (uint32_t c : child)
    for (uint32_t e = head_[c]; e != kNone; e = next_[e]) {
      const uint32_t t = e / 4;
      for (uint32_t k = 0; k < 4; ++k) {
        const uint32_t leaf = h_.tets[4 * size_t{t} + k];
        image[k] = below(u, leaf) ? u : front_vertex(leaf);
      }
      if (image[0] == image[1] || image[0] == image[2] || image[0] == image[3] || image[1] == image[2] || image[1] == image[3] || image[2] == image[3]) continue;
      const uint32_t* s = &h_.tets[4 * size_t{t}];
      if (!(image_volume(image) > 0) && image_volume({s[0], s[1], s[2], s[3]}) > 0) {
        inverted_ = image;
        return false;
      }
    }
  uint64_t gone = 0;
  for (uint32_t m = index_->meet_offsets[j]; m < index_->meet_offsets[j + 1]; ++m) {
    const uint32_t t = index_->meet_tets[m];
    if (meets_left_[t]++ != 0) continue;
    ++gone;  // it lived: out of the stars of its four corners
    for (uint32_t k = 0; k < 4; ++k) {
      const uint32_t e = 4 * t + k, owner = front_vertex(h_.tets[e]);
      uint32_t* link = &head_[owner];
      while (*link != e) link = &next_[*link];
      *link = next_[e];
    }
  }
  applied_[j] = 1;
  for (uint32_t c : child) {
    for (uint32_t e = head_[c], after = 0; e != kNone; e = after) {
      after = next_[e];
      rep_[h_.tets[e]] = u;
      next_[e] = head_[u];
      head_[u] = e;
    }
    head_[c] = kNone;
  }
  tets_ -= gone;
  if (own_[j] <= 0) unseen_added_ -= std::min(unseen_added_, gone);  // its split's tets, counted when it split
  return true;
}

FrontChanges VertexFront::update(const FrontCriteria& criteria, uint64_t budget, FrontSearch search) {
  const std::vector<uint8_t> before = applied_;
  auto done = [&](FrontChanges changes) {
    changes.changed = applied_ != before || !updated_;
    updated_ = true;
    return changes;
  };
  own_ = errors(criteria);
  if (h_.input_tets() <= budget) return done(update_packages(budget));  // every split in view fits: that order is exact
  FrontChanges run_time = update_run_time(budget);
  run_time.run_time_valid = true;
  if (search == FrontSearch::run_time) return done(run_time);
  const std::vector<uint8_t> run_time_front = applied_;
  const uint64_t run_time_tets = tets_;
  FrontChanges packages = update_packages(budget);
  if (packages.estimated_error <= run_time.estimated_error) return done(packages);
  applied_ = run_time_front;
  tets_ = run_time_tets;
  return done(run_time);
}

FrontChanges VertexFront::update_run_time(uint64_t budget) {
  FrontChanges changes;
  changes.budget = budget;
  collapse_all();
  reset_relaxed();
  recollapsed_.assign(h_.collapse_count(), 0);
  unseen_added_ = 0;
  const uint32_t C = h_.collapse_count(), V = h_.input_vertices;
  struct Entry {
    double rank;
    uint32_t collapse;
    bool operator<(const Entry& o) const { return rank < o.rank || (rank == o.rank && collapse < o.collapse); }  // ties: the later collapse first
  };
  // a collapse ranks by its E per tet, or by a higher one below it: the estimate is not
  // monotone up the hierarchy (a parent's sphere may leave the view where a child's meets it)
  std::vector<double> rank(C);
  for (uint32_t i = 0; i < C; ++i) {  // children before parents
    rank[i] = own_[i] / std::max<uint32_t>(h_.nodes[i].fan, 1);
    for (uint32_t c : h_.nodes[i].child)
      if (c >= V) rank[i] = std::max(rank[i], rank[c - V]);
  }
  std::priority_queue<Entry> queue;
  auto enqueue = [&](uint32_t i) {
    if (rank[i] > 0) queue.push({rank[i], i});
  };
  changes.over_budget = tets_ > budget;
  // The coarsest collapses in view first split in the simplification's reverse order, up to a
  // share of the budget: there, around the big cells of a far field, splits ranked out of that
  // order leave neighbours refined that later splits cannot be valid beside.
  // one split with those it needs, its tets counted (forced: those of the others, and all of
  // a split of no E of its own, there for those below it); false when it was not made
  auto take = [&](uint32_t i, uint64_t limit) {
    const uint64_t start = tets_;
    bool over = false;
    last_added_ = 0;
    const bool made = split_relaxed(i, limit, 0, over, true);
    changes.forced_tets += tets_ - start - (made && own_[i] > 0 ? last_added_ : 0);
    if (!made && over) changes.budget_limited = true;
    if (!made && !over) ++changes.refused;
    return made;
  };
  const uint64_t ordered = static_cast<uint64_t>(kOrderedShare * double(budget));
  for (uint32_t i = C; i-- > 0 && tets_ < ordered;)
    if (rank[i] > 0 && applied_[i]) take(i, ordered);
  changes.budget_limited = false;  // the ordered share's own limit
  for (uint32_t i = 0; i < C; ++i)  // the front's vertices
    if (applied_[i] && (parent_[V + i] == kNoCollapse || !applied_[parent_[V + i]])) enqueue(i);
  const uint64_t slack = budget / 200;  // within 0.5% of the budget the front stops looking
  const bool everything_fits = h_.input_tets() <= budget;
  while (!queue.empty()) {
    const uint32_t i = queue.top().collapse;
    queue.pop();
    if (!applied_[i]) continue;
    if (!everything_fits && tets_ + slack >= budget) {
      changes.budget_limited = true;
      break;
    }
    pending_.clear();
    take(i, budget);
    for (uint32_t x : pending_)  // the children of every split joined the front
      for (uint32_t c : h_.nodes[x].child)
        if (c >= V) enqueue(c - V);
  }
  for (uint32_t i = 0; i < C; ++i) {
    if (!applied_[i]) ++changes.splits;
    else changes.estimated_error += own_[i];
  }
  changes.unseen_tets = unseen_added_;
  changes.complete = !changes.budget_limited && changes.refused == 0;
  changes.tets = tets_;
  return changes;
}

}  // namespace tetrascope::lod
