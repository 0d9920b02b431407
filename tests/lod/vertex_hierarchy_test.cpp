// The binary vertex hierarchy (§5.2.1) and its vertex front (§5.2.2–5.2.3): every front
// conforms, splits and collapses round-trip to the exact mesh, the budget is spent, the view
// steers the splits, and vertices.bin refuses damage.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <functional>
#include <random>
#include <set>

#include "mt_fixture.h"
#include "tetrascope/lod/simplify/simplify.h"
#include "tetrascope/lod/vertex/vertex_front.h"
#include "tetrascope/lod/vertex/vertex_hierarchy.h"
#include "tetrascope/storage/store.h"
#include "mesh_checks.h"
#include "test_paths.h"

namespace tetrascope::testing {
namespace {

storage::TetMesh box_mesh() {
  return kuhn_box(16, 0.3, [](double x, double y, double z) { return std::sin(6 * x) * std::cos(4 * y) + z * z; });
}

const lod::VertexHierarchy& hierarchy() {
  static const lod::VertexHierarchy h = lod::build_vertex_hierarchy(box_mesh(), {.base_tets = 300});
  return h;
}

// The front's tets as sorted hierarchy vertex ids.
std::multiset<Tet> front_tets(const lod::VertexFront& front) {
  std::vector<uint32_t> ids;
  const storage::TetMesh m = front.mesh(&ids);
  std::multiset<Tet> out;
  for (size_t t = 0; t < m.tet_count(); ++t) {
    Tet tet{ids[m.tets[4 * t]], ids[m.tets[4 * t + 1]], ids[m.tets[4 * t + 2]], ids[m.tets[4 * t + 3]]};
    std::sort(tet.begin(), tet.end());
    out.insert(tet);
  }
  return out;
}

// Links from an applied collapse to a split one that made a tet it consumes: 0 for a front
// that is a state of the simplification (closed).
size_t open_links(const lod::VertexFront& front) {
  const auto& h = front.hierarchy();
  size_t open = 0;
  for (uint32_t i = 0; i < h.collapse_count(); ++i)
    if (front.applied(i))
      for (uint32_t k = h.before_offsets[i]; k < h.before_offsets[i + 1]; ++k) open += !front.applied(h.before[k]);
  return open;
}

void expect_closed(const lod::VertexFront& front) { EXPECT_EQ(open_links(front), 0u); }

TEST(VertexHierarchy, RecordsEveryCollapseOfTheSimplification) {
  const storage::TetMesh input = box_mesh();
  const auto& h = hierarchy();
  storage::TetMesh simplified = input;
  lod::SimplifyOptions options;
  options.target_tets = 300;
  const lod::SimplifyReport report = lod::simplify(simplified, options);
  EXPECT_EQ(h.collapse_count(), report.collapses);
  EXPECT_EQ(h.base_tets(), simplified.tet_count());
  EXPECT_EQ(h.input_tets(), input.tet_count());
  uint64_t fans = 0;
  for (const auto& n : h.nodes) fans += n.fan;
  EXPECT_EQ(fans + h.base_tets(), input.tet_count());
  EXPECT_GT(h.depth(), 1u);
  // the base mesh is the simplifier's output, vertex for vertex
  lod::VertexFront front(h);
  const storage::TetMesh base = front.mesh();
  EXPECT_EQ(base.vertex_count(), simplified.vertex_count());
  expect_conforming(base, "the base mesh");
}

TEST(VertexHierarchy, SplittingEverythingGivesTheInputExactly) {
  const storage::TetMesh input = box_mesh();
  lod::VertexFront front(hierarchy());
  front.split_all();
  EXPECT_EQ(front.tet_count(), input.tet_count());
  std::multiset<Tet> expected;
  for (size_t t = 0; t < input.tet_count(); ++t) {
    Tet tet{input.tets[4 * t], input.tets[4 * t + 1], input.tets[4 * t + 2], input.tets[4 * t + 3]};
    std::sort(tet.begin(), tet.end());
    expected.insert(tet);
  }
  EXPECT_EQ(front_tets(front), expected);
  const storage::TetMesh mesh = front.mesh();
  ASSERT_EQ(mesh.vertex_count(), input.vertex_count());
  EXPECT_EQ(mesh.attributes.at(0).values, input.attributes.at(0).values);
}

TEST(VertexHierarchy, EveryFrontOfRandomSplitsAndCollapsesConforms) {
  const auto& h = hierarchy();
  lod::VertexFront front(h);
  std::mt19937 rng(7);
  for (int round = 0; round < 12; ++round) {
    for (int k = 0; k < 40; ++k) front.split(rng() % h.collapse_count());
    for (int k = 0; k < 60; ++k) front.collapse(rng() % h.collapse_count());
    expect_closed(front);
    const storage::TetMesh mesh = front.mesh();
    EXPECT_EQ(mesh.tet_count(), front.tet_count()) << "round " << round;
    expect_conforming(mesh, "round " + std::to_string(round));
  }
}

TEST(VertexHierarchy, ASplitAndItsCollapsesRestoreTheExactMesh) {
  const auto& h = hierarchy();
  lod::VertexFront front(h);
  std::mt19937 rng(11);
  for (int k = 0; k < 30; ++k) front.split(rng() % h.collapse_count());
  for (int trial = 0; trial < 20; ++trial) {
    const std::multiset<Tet> before = front_tets(front);
    std::vector<uint8_t> was(h.collapse_count());
    for (uint32_t i = 0; i < h.collapse_count(); ++i) was[i] = front.applied(i);
    front.split(rng() % h.collapse_count());
    // collapse back what the split (and those it forced) undid, earliest collapse first
    for (uint32_t i = 0; i < h.collapse_count(); ++i)
      if (was[i] && !front.applied(i)) {
        ASSERT_TRUE(front.collapse(i)) << "collapse " << i;
      }
    EXPECT_EQ(front_tets(front), before) << "trial " << trial;
  }
}

TEST(VertexFront, SpendsItsBudgetAndNeverPassesIt) {
  const auto& h = hierarchy();
  lod::VertexFront front(h);
  const lod::FrontCriteria criteria;  // no view: the hierarchy's errors alone
  uint32_t max_fan = 0;
  for (const auto& n : h.nodes) max_fan = std::max(max_fan, n.fan);
  double last_error = INFINITY;
  for (uint64_t budget : {600, 1200, 2400, 4800, 9600, 30000}) {
    const lod::FrontChanges changes = front.update(criteria, budget);
    EXPECT_LE(changes.tets, budget);
    // within a fan or 0.5% of the budget (where the front stops looking)
    EXPECT_GE(changes.tets + std::max<uint64_t>(max_fan, budget / 200), std::min<uint64_t>(budget, h.input_tets())) << "budget " << budget;
    EXPECT_EQ(front.mesh().tet_count(), changes.tets);
    EXPECT_LE(changes.estimated_error, last_error);
    last_error = changes.estimated_error;
  }
  const lod::FrontChanges small = front.update(criteria, 10);
  EXPECT_TRUE(small.over_budget);
  EXPECT_EQ(small.tets, h.base_tets());
}

TEST(VertexFront, RefinesWhatTheViewShowsFirst) {
  const auto& h = hierarchy();
  lod::VertexFront front(h);
  lod::FrontCriteria criteria;
  view::Camera camera;
  camera.eye = {0.1, 0.1, 0.1};  // inside the box, in one corner, looking at it
  camera.target = {0, 0, 0};
  camera.up = {0, 0, 1};
  camera.fov_degrees = 40;
  criteria.camera = camera;
  // tets near the eye's corner, with the view and without (the simplifier's order)
  auto near_tets = [&](const lod::FrontCriteria& c) {
    front.update(c, 8000);
    const storage::TetMesh mesh = front.mesh();
    size_t near = 0;
    for (size_t t = 0; t < mesh.tet_count(); ++t) {
      double sum = 0;
      for (int k = 0; k < 4; ++k) sum += mesh.x[mesh.tets[4 * t + k]] + mesh.y[mesh.tets[4 * t + k]] + mesh.z[mesh.tets[4 * t + k]];
      near += sum / 4 < 0.6;
    }
    return near;
  };
  const size_t uniform = near_tets({}), viewed = near_tets(criteria);
  EXPECT_GT(viewed, 1.3 * double(uniform)) << "near the eye: " << viewed << " tets with the view, " << uniform << " without";
  expect_conforming(front.mesh(), "the view's front");
}

// The splits a view forces: an eye inside the box needs the later collapses around it split,
// some of them behind it; the front counts their tets (forced, and of them unseen) within
// the tets it added. Without a view nothing is unseen.
TEST(VertexFront, CountsTheTetsItsSplitsForcedOutOfView) {
  const auto& h = hierarchy();
  lod::VertexFront front(h);
  lod::FrontCriteria criteria;
  view::Camera camera;
  camera.eye = {0.1, 0.1, 0.1};
  camera.target = {0, 0, 0};
  camera.up = {0, 0, 1};
  camera.fov_degrees = 40;
  criteria.camera = camera;
  const lod::FrontChanges viewed = front.update(criteria, 8000);
  EXPECT_GT(viewed.unseen_tets, 0u);
  EXPECT_LE(viewed.unseen_tets, viewed.forced_tets);
  EXPECT_LE(viewed.forced_tets, viewed.tets - h.base_tets());
  const lod::FrontChanges uniform = front.update({}, 8000);
  EXPECT_EQ(uniform.unseen_tets, 0u);
  EXPECT_LE(uniform.forced_tets, uniform.tets - h.base_tets());
}

// Packages ranked by the error they remove per tet leave less of the view's estimate than
// splitting in the hierarchy's own order (the simplification reversed) to as many tets, with
// the eye inside the box, where forced splits reach out of view.
TEST(VertexFront, LeavesLessOfTheViewsEstimateThanTheHierarchysOwnOrder) {
  const auto& h = hierarchy();
  lod::FrontCriteria criteria;
  view::Camera camera;
  camera.eye = {0.2, 0.5, 0.5};
  camera.target = {0.9, 0.5, 0.5};
  camera.up = {0, 0, 1};
  camera.fov_degrees = 50;
  criteria.camera = camera;
  const std::vector<double> own = lod::VertexFront(h).errors(criteria);
  for (uint64_t budget : {1500, 3000, 6000}) {
    lod::VertexFront ranked(h);
    const lod::FrontChanges changes = ranked.update(criteria, budget);
    lod::VertexFront ordered(h);
    for (uint32_t i = h.collapse_count(); i-- > 0 && ordered.tet_count() + h.nodes[i].fan <= changes.tets;) ordered.split(i);
    double left = 0;
    for (uint32_t i = 0; i < h.collapse_count(); ++i)
      if (ordered.applied(i)) left += own[i];
    EXPECT_LE(ordered.tet_count(), changes.tets);
    EXPECT_LT(changes.estimated_error, left) << "budget " << budget << ": " << changes.tets << " tets ranked, " << ordered.tet_count() << " in order";
    expect_conforming(ranked.mesh(), "the ranked front");
  }
}

// Splits are valid at run time (every tet they change stays positively oriented), not only
// in the simplification's order: fronts for views drawn at random, eyes inside and outside,
// conform, and most of them are not states of the simplification (an applied collapse with
// a collapse before it that made one of its tets split).
TEST(VertexFront, FrontsOfRandomViewsConformWithoutTheSimplificationsOrder) {
  const auto& h = hierarchy();
  lod::VertexFront front(h);
  std::mt19937 rng(20261139);
  std::uniform_real_distribution<double> unit(0, 1);
  size_t open_fronts = 0;
  const int views = 16;
  for (int view = 0; view < views; ++view) {
    lod::FrontCriteria criteria;
    view::Camera camera;
    const bool inside = view % 2 == 0;
    camera.eye = inside ? std::array<double, 3>{unit(rng), unit(rng), unit(rng)} : std::array<double, 3>{2.5 * unit(rng) - 0.75, -1.5, 2 * unit(rng) - 0.5};
    camera.target = {unit(rng), unit(rng), unit(rng)};
    camera.up = {0, 0, 1};
    camera.fov_degrees = 30 + 50 * unit(rng);
    criteria.camera = camera;
    const uint64_t budget = 600 + rng() % 12000;
    const lod::FrontChanges changes = front.update(criteria, budget);
    const std::string what = "view " + std::to_string(view) + (inside ? " (inside)" : " (outside)") + ", budget " + std::to_string(budget);
    EXPECT_LE(changes.tets, budget) << what;
    EXPECT_EQ(front.mesh().tet_count(), changes.tets) << what;
    expect_conforming(front.mesh(), what);
    open_fronts += open_links(front) > 0;
    // the quicker search (a moving view's): the run-time front alone, no better than the best
    const lod::FrontChanges quick = front.update(criteria, budget, lod::FrontSearch::run_time);
    EXPECT_TRUE(quick.run_time_valid) << what;
    EXPECT_GE(quick.estimated_error, changes.estimated_error) << what;
    EXPECT_LE(quick.tets, budget) << what;
    expect_conforming(front.mesh(), what + ", the quicker search");
  }
  EXPECT_GE(open_fronts, size_t{views / 2}) << "fronts that are not states of the simplification";
}

TEST(VertexFront, LeavesWhatNoOpacityShowsCoarse) {
  const auto& h = hierarchy();
  lod::VertexFront front(h);
  view::TransferFunction tf;
  tf.attribute = "f";
  tf.range = {{-1, 2}};
  tf.opacity = {{-1, 0}, {1.5, 0}, {1.6, 1}, {2, 1}};  // shows only the top of the field
  // tets with some vertex over 1.2 (near z = 1, where z² lifts f), with the transfer function
  // and without (the simplifier's order)
  auto shown_tets = [&](const lod::FrontCriteria& c) {
    front.update(c, 8000);
    const storage::TetMesh mesh = front.mesh();
    size_t shown = 0;
    for (size_t t = 0; t < mesh.tet_count(); ++t) {
      float top = -INFINITY;
      for (int k = 0; k < 4; ++k) top = std::max(top, mesh.attributes[0].values[mesh.tets[4 * t + k]]);
      shown += top > 1.2f;
    }
    return shown;
  };
  const size_t uniform = shown_tets({}), classified = shown_tets(lod::front_criteria(h, tf));
  EXPECT_GT(classified, 1.05 * double(uniform)) << "where the opacity is: " << classified << " tets with the transfer function, " << uniform << " without";
}

TEST(VertexHierarchyFile, RoundTripsExactly) {
  const auto& h = hierarchy();
  const auto path = scratch_dir("vertex_hierarchy") / "vertices.bin";
  lod::write_vertex_hierarchy(path, h);
  const lod::VertexHierarchy back = lod::read_vertex_hierarchy(path);
  EXPECT_EQ(back.positions, h.positions);
  EXPECT_EQ(back.values, h.values);
  EXPECT_EQ(back.tets, h.tets);
  EXPECT_EQ(back.killer, h.killer);
  EXPECT_EQ(back.after, h.after);
  EXPECT_EQ(back.before, h.before);
  ASSERT_EQ(back.attributes.size(), 1u);
  EXPECT_EQ(back.attributes[0].name, "f");
  lod::VertexFront a(h), b(back);
  a.split_all();
  b.split_all();
  EXPECT_EQ(front_tets(a), front_tets(b));
}

// Version 2 writes neither the killers, the fans and the before links, nor (where replaying the
// collapses gives them back, flag 4) the value ranges and the after links: each derived equal to
// what the build recorded, from a file that leaves them out and from one that holds them.
TEST(VertexHierarchyFile, VersionTwoDerivesTheKillersFansRangesAndLinksTheBuildRecorded) {
  const auto& h = hierarchy();
  const auto derived = scratch_dir("vertex_hierarchy_v2") / "vertices.bin";
  const auto held = scratch_dir("vertex_hierarchy_v2_links") / "vertices.bin";
  lod::write_vertex_hierarchy(derived, h);
  lod::write_vertex_hierarchy(held, h, {.derive_star_links = false});
  auto flags_of = [](const std::filesystem::path& path) {
    std::ifstream in(path, std::ios::binary);
    std::string header(44, '\0');
    in.read(header.data(), 44);
    uint32_t flags = 0;
    std::memcpy(&flags, header.data() + 40, 4);
    return flags;
  };
  EXPECT_EQ(flags_of(derived), 4u);
  EXPECT_EQ(flags_of(held), 0u);
  EXPECT_LT(std::filesystem::file_size(derived), std::filesystem::file_size(held));
  for (const auto& path : {derived, held}) {
    const lod::VertexHierarchy back = lod::read_vertex_hierarchy(path);
    ASSERT_EQ(back.nodes.size(), h.nodes.size());
    for (size_t i = 0; i < h.nodes.size(); ++i) {
      EXPECT_EQ(back.nodes[i].child, h.nodes[i].child) << "collapse " << i;
      EXPECT_EQ(back.nodes[i].fan, h.nodes[i].fan) << "collapse " << i;
      EXPECT_EQ(back.nodes[i].error, h.nodes[i].error) << "collapse " << i;
      EXPECT_EQ(back.nodes[i].radius, h.nodes[i].radius) << "collapse " << i;
    }
    EXPECT_EQ(back.killer, h.killer) << path;
    EXPECT_EQ(back.before_offsets, h.before_offsets) << path;
    EXPECT_EQ(back.before, h.before) << path;
    EXPECT_EQ(back.after_offsets, h.after_offsets) << path;
    EXPECT_EQ(back.after, h.after) << path;
    EXPECT_EQ(back.ranges, h.ranges) << path;
  }
  // and smaller than the arrays it holds
  const auto v1 = scratch_dir("vertex_hierarchy_v1") / "vertices.bin";
  lod::write_vertex_hierarchy(v1, h, {.version = 1});
  EXPECT_LT(std::filesystem::file_size(derived), std::filesystem::file_size(v1) * 3 / 4);
}

// preprocess leaves the input's vertices to segments.bin when they are the hierarchy's leaves:
// the file read back is the one written whole, and a file moved away from its store is refused.
TEST(VertexHierarchyFile, AStoresFileReadsItsInputVerticesFromTheSegments) {
  const auto& store = built("sample").store;
  const auto file = store / lod::kVertexHierarchyFile;
  ASSERT_TRUE(std::filesystem::exists(file));
  std::ifstream in(file, std::ios::binary);
  std::string header(44, '\0');
  in.read(header.data(), 44);
  uint32_t version = 0, flags = 0;
  std::memcpy(&version, header.data() + 8, 4);
  std::memcpy(&flags, header.data() + 40, 4);
  EXPECT_EQ(version, 2u);
  EXPECT_EQ(flags, 7u) << "the sample's vertices and tets are the store's, its ranges and after links derived: the file should leave them out";
  const lod::VertexHierarchy h = lod::read_vertex_hierarchy(file);
  const auto whole = scratch_dir("vertex_hierarchy_whole") / "vertices.bin";
  lod::write_vertex_hierarchy(whole, h);
  EXPECT_LT(std::filesystem::file_size(file), std::filesystem::file_size(whole));
  const lod::VertexHierarchy back = lod::read_vertex_hierarchy(whole);
  EXPECT_EQ(back.positions, h.positions);
  EXPECT_EQ(back.values, h.values);
  EXPECT_EQ(back.killer, h.killer);
  // the leaves read from the segments are the sample mesh's vertices
  const storage::TetMesh mesh = storage::load_mesh(sample_mesh());
  ASSERT_EQ(h.input_vertices, mesh.vertex_count());
  for (uint32_t v = 0; v < h.input_vertices; v += 37) {
    EXPECT_EQ(h.positions[3 * size_t{v}], mesh.x[v]) << "vertex " << v;
    EXPECT_EQ(h.positions[3 * size_t{v} + 2], mesh.z[v]) << "vertex " << v;
  }
  // and the tets read from the segments are the mesh's, each once, in another order
  auto sorted_tets = [](const std::vector<uint32_t>& tets) {
    std::multiset<std::array<uint32_t, 4>> out;
    for (size_t t = 0; t < tets.size(); t += 4) {
      std::array<uint32_t, 4> q = {tets[t], tets[t + 1], tets[t + 2], tets[t + 3]};
      std::sort(q.begin(), q.end());
      out.insert(q);
    }
    return out;
  };
  EXPECT_EQ(sorted_tets(h.tets), sorted_tets(mesh.tets));
  lod::VertexFront front(h);
  front.split_all();
  EXPECT_EQ(front.tet_count(), mesh.tet_count());
  // moved away from its store: a clear error naming what is missing
  const auto alone = scratch_dir("vertex_hierarchy_alone") / "vertices.bin";
  std::filesystem::copy_file(file, alone, std::filesystem::copy_options::overwrite_existing);
  try {
    lod::read_vertex_hierarchy(alone);
    FAIL() << "read without its store";
  } catch (const lod::VertexHierarchyError& e) {
    EXPECT_NE(std::string(e.what()).find("segments"), std::string::npos) << e.what();
  }
}

TEST(VertexHierarchyFile, AVersionOneFileIsStillRead) {
  const auto& h = hierarchy();
  const auto path = scratch_dir("vertex_hierarchy_v1_read") / "vertices.bin";
  lod::write_vertex_hierarchy(path, h, {.version = 1});
  const lod::VertexHierarchy back = lod::read_vertex_hierarchy(path);
  EXPECT_EQ(back.tets, h.tets);
  EXPECT_EQ(back.killer, h.killer);
  EXPECT_EQ(back.before, h.before);
  EXPECT_EQ(back.values, h.values);
  EXPECT_THROW(lod::write_vertex_hierarchy(path, h, {.version = 3}), std::invalid_argument);
}

// A file whose checksums are right but whose coded sections lie (a writer's bug, or a file made
// to pass the checksums): each lie refused by name, nothing allocated beyond the counts.
TEST(VertexHierarchyFile, AVersionTwoFileWithLyingSectionsIsRefused) {
  const auto path = scratch_dir("vertex_hierarchy_lies") / "vertices.bin";
  lod::write_vertex_hierarchy(path, hierarchy(), {.derive_star_links = false});
  std::string good;
  {
    std::ifstream in(path, std::ios::binary);
    good.assign((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  }
  constexpr size_t kFixed = 44, kEntry = 32, kSections = 9, kHeader = kFixed + kSections * kEntry + 4;
  auto rewrite = [&](const std::function<void(std::string&)>& change) {
    std::string bytes = good;
    change(bytes);
    const uint32_t crc = storage::crc32_of(bytes.data(), kHeader - 4);
    std::memcpy(bytes.data() + kHeader - 4, &crc, 4);
    std::ofstream(path, std::ios::binary | std::ios::trunc).write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  };
  auto raw_bytes_at = [&](size_t section) { return kFixed + section * kEntry + 16; };
  // the positions claim a hundred times their size: refused before inflating
  rewrite([&](std::string& b) {
    uint64_t raw;
    std::memcpy(&raw, b.data() + raw_bytes_at(1), 8);
    raw *= 100;
    std::memcpy(b.data() + raw_bytes_at(1), &raw, 8);
  });
  EXPECT_THROW(lod::read_vertex_hierarchy(path), lod::VertexHierarchyError);
  // the tets claim the codec of numbers
  rewrite([&](std::string& b) {
    const uint32_t varint = 2;
    std::memcpy(b.data() + raw_bytes_at(3) + 8, &varint, 4);
  });
  EXPECT_THROW(lod::read_vertex_hierarchy(path), lod::VertexHierarchyError);
  // the after links claim one byte fewer than they inflate to
  rewrite([&](std::string& b) {
    uint64_t raw;
    std::memcpy(&raw, b.data() + raw_bytes_at(8), 8);
    --raw;
    std::memcpy(b.data() + raw_bytes_at(8), &raw, 8);
  });
  EXPECT_THROW(lod::read_vertex_hierarchy(path), lod::VertexHierarchyError);
  // the flags say the ranges and after links are derived, but their sections hold bytes
  rewrite([&](std::string& b) {
    const uint32_t flags = 4;
    std::memcpy(b.data() + 40, &flags, 4);
  });
  EXPECT_THROW(lod::read_vertex_hierarchy(path), lod::VertexHierarchyError);
  // a flag this build does not know
  rewrite([&](std::string& b) {
    const uint32_t flags = 8;
    std::memcpy(b.data() + 40, &flags, 4);
  });
  EXPECT_THROW(lod::read_vertex_hierarchy(path), lod::VertexHierarchyError);
  // a version this build does not know
  rewrite([&](std::string& b) {
    const uint32_t version = 7;
    std::memcpy(b.data() + 8, &version, 4);
  });
  EXPECT_THROW(lod::read_vertex_hierarchy(path), lod::VertexHierarchyError);
}

TEST(VertexHierarchyFile, ATruncatedVerticesFileIsRefusedWithAClearError) {
  const auto path = scratch_dir("vertex_hierarchy_truncated") / "vertices.bin";
  lod::write_vertex_hierarchy(path, hierarchy());
  const auto size = std::filesystem::file_size(path);
  for (uintmax_t keep : {uintmax_t{0}, uintmax_t{20}, size / 2, size - 1}) {
    std::filesystem::resize_file(path, keep);
    EXPECT_THROW(lod::read_vertex_hierarchy(path), lod::VertexHierarchyError) << keep << " bytes";
    lod::write_vertex_hierarchy(path, hierarchy());
  }
}

TEST(VertexHierarchyFile, AFlippedBitFailsItsChecksum) {
  const auto path = scratch_dir("vertex_hierarchy_flipped") / "vertices.bin";
  lod::write_vertex_hierarchy(path, hierarchy());
  const auto size = std::filesystem::file_size(path);
  std::mt19937 rng(3);
  for (int trial = 0; trial < 8; ++trial) {
    lod::write_vertex_hierarchy(path, hierarchy());
    const uintmax_t at = rng() % size;
    std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
    f.seekg(static_cast<std::streamoff>(at));
    char c = 0;
    f.read(&c, 1);
    c = static_cast<char>(c ^ (1 << (rng() % 8)));
    f.seekp(static_cast<std::streamoff>(at));
    f.write(&c, 1);
    f.close();
    EXPECT_THROW(lod::read_vertex_hierarchy(path), lod::VertexHierarchyError) << "byte " << at;
  }
}

}  // namespace
}  // namespace tetrascope::testing
