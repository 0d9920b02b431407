// libFuzzer target for the store loader: manifest.json, segments.bin, dag.bin and variants.bin
// are untrusted (a store directory may be copied in from anywhere). The input holds the files
// separated by lines "#segments.bin", "#dag.bin" and "#variants.bin"; they are written to a
// scratch directory and opened as `tetrascope verify` and the server open them, every variant
// viewed as a cut would. Any outcome but success or a StoreError/DagError/VariantsError is a
// bug (ASan/UBSan report the rest).
#include <cstddef>
#include <cstdint>
#include <filesystem>

#include "store_input.h"
#include "tetrascope/lod/cut/dag.h"
#include "tetrascope/lod/cut/variants.h"
#include "tetrascope/storage/store.h"
#include "tetrascope/storage/store_verify.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::filesystem::path dir = tetrascope::fuzz::scratch_folder("tetrascope_fuzz_store");
  tetrascope::fuzz::write_store_input(dir, data, size);

  (void)tetrascope::storage::verify_store(dir);  // never throws for a damaged store
  try {
    auto store = tetrascope::storage::Store::open(dir);
    for (uint32_t s = 0; s < store->segment_count(); ++s) store->map_segment(s);
    if (auto opened = tetrascope::lod::open_dag(*store)) {
      (void)tetrascope::lod::verify_dag(*store, *opened);
      (void)tetrascope::lod::verify_variants(*store, *opened);
      if (auto v = tetrascope::lod::Variants::open(*store, *opened))
        for (uint32_t n = 0; n < opened->node_count(); ++n)
          for (uint32_t j = 0; j < v->count(n); ++j) (void)v->view(n, j);
    }
  } catch (const tetrascope::storage::StoreError&) {
  } catch (const tetrascope::lod::DagError&) {
  } catch (const tetrascope::lod::VariantsError&) {
  }
  return 0;
}
