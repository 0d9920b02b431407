// Compressed segments, on one core: how fast the cut-border stream decodes
// (segment_codec.h; the dissertation's decoder managed 500K tets/s, §6.3.5), and what a segment
// swap costs - Store::map_segment (map, checksum, decode, validate) from a warm page cache and
// from disk (the store's pages dropped from the page cache first) - for each compression.
//   segment_codec_bench --store none=DIR --store index16=DIR --store cutborder=DIR [benchmark flags]
// Counters: tets_per_second (items/s), bytes_per_tet (of the segments read).
#include <fcntl.h>
#include <unistd.h>

#include <benchmark/benchmark.h>

#include <cstdio>
#include <cstring>
#include <map>
#include <string>
#include <vector>

#include "tetrascope/storage/segment_codec.h"
#include "tetrascope/storage/store.h"

using namespace tetrascope;

namespace {

// Every segment's raw bytes, read once, for decoding without I/O.
struct Streams {
  std::vector<std::vector<uint8_t>> bytes;
  std::vector<storage::store::SegmentLayout> layouts;
  uint64_t tets = 0, stream_bytes = 0;
};

Streams read_streams(const storage::Store& store) {
  Streams s;
  const int fd = ::open((store.path() / "segments.bin").c_str(), O_RDONLY | O_CLOEXEC);
  for (uint32_t i = 0; i < store.segment_count(); ++i) {
    const auto& r = store.record(i);
    std::vector<uint8_t> bytes(r.bytes);
    if (::pread(fd, bytes.data(), bytes.size(), static_cast<off_t>(r.offset)) != static_cast<ssize_t>(bytes.size())) throw std::runtime_error("short read");
    storage::store::SegmentHeader h;
    std::memcpy(&h, bytes.data(), sizeof h);
    s.layouts.push_back(storage::store::segment_layout(r.vertex_count, r.tet_count, r.link_count, store.header().floats_per_vertex, store.compression(), h.stream_bytes));
    s.tets += r.tet_count;
    s.stream_bytes += h.stream_bytes;
    s.bytes.push_back(std::move(bytes));
  }
  ::close(fd);
  return s;
}

// Decoding alone: the stream (or the uint16 tets) to uint32 tets and opposites, every segment.
void decode(benchmark::State& state, const storage::Store* store, const Streams* streams) {
  std::vector<uint32_t> tets, opposites;
  for (auto _ : state) {
    for (uint32_t i = 0; i < store->segment_count(); ++i) {
      const auto& r = store->record(i);
      const auto& l = streams->layouts[i];
      const uint8_t* bytes = streams->bytes[i].data();
      tets.resize(4 * size_t{r.tet_count});
      opposites.resize(4 * size_t{r.tet_count});
      if (l.tet_index_bytes == 0) {
        const auto* links = reinterpret_cast<const storage::store::BorderLink*>(bytes + l.links);
        const std::string error = storage::decode_tets(std::span<const uint8_t>(bytes + l.tets, r.bytes - l.tets), r.vertex_count, r.tet_count,
                                                       std::span(links, r.link_count), tets, opposites);
        if (!error.empty()) state.SkipWithError(error.c_str());
      } else if (l.tet_index_bytes == 2) {
        const auto* narrow = reinterpret_cast<const uint16_t*>(bytes + l.tets);
        std::copy(narrow, narrow + tets.size(), tets.begin());
      }
      benchmark::DoNotOptimize(tets.data());
      benchmark::DoNotOptimize(opposites.data());
    }
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * streams->tets));
  state.counters["stream_bytes_per_tet"] = double(streams->stream_bytes) / double(streams->tets);
}

// A swap: every segment mapped, checksummed, decoded and validated; `cold` drops the file's
// pages from the page cache before each pass (posix_fadvise; the file is clean, so it works
// without privileges), so the pass reads from disk.
void map_all(benchmark::State& state, const storage::Store* store, bool cold) {
  uint64_t tets = 0, bytes = 0;
  for (uint32_t i = 0; i < store->segment_count(); ++i) {
    tets += store->record(i).tet_count;
    bytes += store->record(i).bytes;
  }
  const int fd = ::open((store->path() / "segments.bin").c_str(), O_RDONLY | O_CLOEXEC);
  for (auto _ : state) {
    if (cold) {
      state.PauseTiming();
      ::posix_fadvise(fd, 0, 0, POSIX_FADV_DONTNEED);
      state.ResumeTiming();
    }
    for (uint32_t i = 0; i < store->segment_count(); ++i) {
      auto segment = store->map_segment(i);
      benchmark::DoNotOptimize(segment->view().tets.data());
    }
  }
  ::close(fd);
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * tets));
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations() * bytes));
  state.counters["segment_bytes_per_tet"] = double(bytes) / double(tets);
}

}  // namespace

int main(int argc, char** argv) {
  std::map<std::string, std::string> stores;
  std::vector<char*> rest{argv[0]};
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--store") && i + 1 < argc) {
      const std::string spec = argv[++i];
      const size_t eq = spec.find('=');
      if (eq == std::string::npos) {
        std::fprintf(stderr, "--store NAME=DIR\n");
        return 2;
      }
      stores[spec.substr(0, eq)] = spec.substr(eq + 1);
    } else {
      rest.push_back(argv[i]);
    }
  }
  if (stores.empty()) {
    std::fprintf(stderr, "usage: segment_codec_bench --store NAME=DIR ... [benchmark flags]\n");
    return 2;
  }
  std::vector<std::unique_ptr<storage::Store>> opened;
  std::vector<std::unique_ptr<Streams>> streams;
  for (const auto& [name, dir] : stores) {
    opened.push_back(storage::Store::open(dir));
    streams.push_back(std::make_unique<Streams>(read_streams(*opened.back())));
    const storage::Store* store = opened.back().get();
    const Streams* s = streams.back().get();
    if (store->compression() != storage::store::Compression::kNone) benchmark::RegisterBenchmark(("decode/" + name).c_str(), decode, store, s)->Unit(benchmark::kMillisecond);
    benchmark::RegisterBenchmark(("swap_warm/" + name).c_str(), map_all, store, false)->Unit(benchmark::kMillisecond);
    benchmark::RegisterBenchmark(("swap_cold/" + name).c_str(), map_all, store, true)->Unit(benchmark::kMillisecond);
  }
  int rest_count = static_cast<int>(rest.size());
  benchmark::Initialize(&rest_count, rest.data());
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
