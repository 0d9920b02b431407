// Boundary regions on a multiresolution store (renderer/boundary_regions.h): what a dataset's
// open pays (the finest cut assembled, its boundary split into regions, the map's hierarchy
// built) and what each scene pays (its boundary faces classified by the map), for the
// coarsest cut and the finest, best of `--repeat` runs; the regions found.
//   regions_bench STORE [--repeat N]   -> one JSON object
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <string>
#include <thread>

#include <nlohmann/json.hpp>

#include "tetrascope/lod/cut/cut.h"
#include "tetrascope/lod/cut/dag.h"
#include "tetrascope/renderer/boundary_regions.h"
#include "tetrascope/renderer/render.h"
#include "tetrascope/storage/store.h"

using namespace tetrascope;
using clock_type = std::chrono::steady_clock;

namespace {

template <class Work>
double best_ms(int repeat, Work&& work) {
  double best = 1e300;
  for (int r = 0; r < repeat; ++r) {
    const auto t0 = clock_type::now();
    work();
    best = std::min(best, std::chrono::duration<double, std::milli>(clock_type::now() - t0).count());
  }
  return best;
}

// Faces of `scene` classified, and how many belong to no region.
nlohmann::json classified(const renderer::RegionMap& map, const renderer::SceneMesh& scene, int repeat) {
  std::vector<uint32_t> region;
  const double ms = best_ms(repeat, [&] { region = map.classify(scene); });
  return {{"tets", scene.tets.size() / 4},
          {"boundary_faces", scene.boundary.size()},
          {"classify_ms", ms},
          {"no_region", std::count(region.begin(), region.end(), renderer::kNoRegion)}};
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: regions_bench STORE [--repeat N]\n");
    return 2;
  }
  int repeat = 3;
  for (int i = 2; i + 1 < argc; i += 2)
    if (!std::strcmp(argv[i], "--repeat")) repeat = std::max(1, std::stoi(argv[i + 1]));
  try {
    auto store = storage::Store::open(argv[1]);
    auto dag = lod::open_dag(*store);
    if (!dag) throw std::runtime_error("not a multiresolution store");
    storage::SegmentCache cache(*store, uint64_t{256} << 20);
    storage::TetMesh finest_mesh;
    const double assemble_ms = best_ms(repeat, [&] {
      lod::Cut finest(*dag);
      finest.refine_all();
      finest_mesh = lod::assemble_cut(*store, cache, finest, false).mesh;
    });
    std::shared_ptr<const renderer::RegionMap> map;
    const double regions_ms = best_ms(repeat, [&] { map = renderer::RegionMap::from(finest_mesh); });
    const std::string attribute = finest_mesh.attributes.empty() ? "" : finest_mesh.attributes.front().info.name;
    const renderer::SceneMesh finest = renderer::SceneMesh::from(finest_mesh, attribute);
    const renderer::SceneMesh coarsest = renderer::SceneMesh::from(lod::assemble_cut(*store, cache, lod::Cut(*dag), false).mesh, attribute);
    nlohmann::json regions = nlohmann::json::array();
    for (const auto& r : map->regions())
      regions.push_back({{"id", r.id}, {"triangles", r.triangles}, {"area", r.area}, {"touches_domain_box", r.touches_domain_box}});
    nlohmann::json out = {{"store", argv[1]},
                          {"input_tets", finest_mesh.tet_count()},
                          {"threads", std::thread::hardware_concurrency()},
                          {"repeat", repeat},
                          {"finest_cut_assemble_ms", assemble_ms},
                          {"find_regions_ms", regions_ms},
                          {"regions", regions},
                          {"coarsest", classified(*map, coarsest, repeat)},
                          {"finest", classified(*map, finest, repeat)}};
    std::printf("%s\n", out.dump(1).c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "regions_bench: %s\n", e.what());
    return 1;
  }
  return 0;
}
