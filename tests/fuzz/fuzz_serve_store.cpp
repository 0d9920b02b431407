// libFuzzer target for a store through the server's own path: a damaged store as a dataset of
// `serve --data`, opened by the server's registry (its checks at open), then a frame maker draws
// a refinement step and a full still of it with a real renderer and answers a probe, as a
// session's turn does. The server answers any std::exception of these as an error to that
// session (and closes the dataset for store damage); anything else - a crash, a sanitizer
// report, a hang - is a bug. Input: as fuzz_store (store_input.h).
#include <cstddef>
#include <cstdint>
#include <exception>
#include <filesystem>
#include <memory>

#include "../../server/src/datasets.h"
#include "../../server/src/frame_maker.h"
#include "store_input.h"

namespace {

using namespace tetrascope;

server::Worker& worker() {
  static server::Worker w = [] {
    server::Worker made;
    try {
      made.renderer = renderer::Renderer::create();
      server::warm_up(*made.renderer);
    } catch (const std::exception&) {  // no EGL here: open and cut are fuzzed still
    }
    return made;
  }();
  return w;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::filesystem::path root = fuzz::scratch_folder("tetrascope_fuzz_serve_store");
  std::filesystem::create_directories(root / "s");
  fuzz::write_store_input(root / "s", data, size);
  server::DatasetRegistry registry(root, 16ull << 20);  // one budget for the dataset's segments, as serve's
  std::shared_ptr<server::Dataset> dataset;
  try {
    dataset = registry.open("s");
  } catch (const std::exception&) {  // refused with a message (dataset.open's error reply)
    return 0;
  }
  server::Worker& w = worker();
  server::FrameMaker frames;
  server::ServerOptions options;
  server::FrameCostModel cost;
  server::ViewState state;
  state.dataset = dataset;
  state.view.width = state.view.height = 24;
  state.view.budget = 1u << 20;  // every segment the store holds
  for (const bool refinement : {false, true}) {
    server::FramePlan plan;
    plan.refinement = refinement;
    try {
      if (w.renderer) (void)frames.render(state, plan, cost, options, w, 1);
    } catch (const std::exception& e) {
      if (server::is_store_damage(e)) (void)registry.close_damaged(dataset, e.what());
    }
  }
  try {
    (void)frames.probe(state, 12, 12, 1);
  } catch (const std::exception&) {
  }
  return 0;
}
