// libFuzzer target for the store loader: manifest.json, segments.bin, dag.bin and variants.bin
// are untrusted (a store directory may be copied in from anywhere). The input holds the files
// separated by lines "#segments.bin", "#dag.bin" and "#variants.bin"; they are written to a
// scratch directory and opened as `tetrascope verify` and the server open them, every variant
// viewed as a cut would. Any outcome but success or a StoreError/DagError/VariantsError is a
// bug (ASan/UBSan report the rest).
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>

#include "tetrascope/lod/dag.h"
#include "tetrascope/lod/variants.h"
#include "tetrascope/storage/store.h"
#include "tetrascope/storage/store_verify.h"

namespace {

void write(const std::filesystem::path& path, std::string_view bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

const std::filesystem::path& scratch() {
  static const std::filesystem::path dir = [] {
    std::filesystem::path base = std::filesystem::exists("/dev/shm") ? "/dev/shm" : std::filesystem::temp_directory_path();
    auto d = base / ("tetrascope_fuzz_store_" + std::to_string(::getpid()));
    std::filesystem::create_directories(d);
    return d;
  }();
  return dir;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::string_view bytes(reinterpret_cast<const char*>(data), size);
  std::string_view manifest = bytes, segments, dag, variants;
  if (size_t at = manifest.find("\n#segments.bin\n"); at != std::string_view::npos) {
    segments = manifest.substr(at + 15);
    manifest = manifest.substr(0, at + 1);
  }
  if (size_t at = segments.find("\n#dag.bin\n"); at != std::string_view::npos) {
    dag = segments.substr(at + 10);
    segments = segments.substr(0, at);
  }
  if (size_t at = dag.find("\n#variants.bin\n"); at != std::string_view::npos) {
    variants = dag.substr(at + 15);
    dag = dag.substr(0, at);
  }
  const auto& dir = scratch();
  write(dir / "manifest.json", manifest);
  write(dir / "segments.bin", segments);
  std::filesystem::remove(dir / "dag.bin");
  if (!dag.empty()) write(dir / "dag.bin", dag);
  std::filesystem::remove(dir / "variants.bin");
  if (!variants.empty()) write(dir / "variants.bin", variants);

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
