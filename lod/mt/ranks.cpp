// The seam over MPI (ranks.h): Open MPI's C interface when built with TETRA_MPI, else one
// rank. Only the main thread calls MPI (MPI_THREAD_FUNNELED): the worker threads of a rank
// simplify, the main thread exchanges.
#include "tetrascope/lod/mt/ranks.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <stdexcept>
#include <thread>

#if TETRA_HAVE_MPI
#include <mpi.h>
#endif

namespace tetrascope::lod {
namespace {

// What the launcher told the process: its rank and the launch's size (0: not said).
struct LaunchEnvironment {
  bool launched = false;
  long rank = 0, size = 0;
};

long env_number(const char* name, long fallback) {
  const char* value = std::getenv(name);
  if (!value || !*value) return fallback;
  char* end = nullptr;
  const long number = std::strtol(value, &end, 10);
  return end && *end == 0 ? number : fallback;
}

LaunchEnvironment launch_environment() {
  LaunchEnvironment env;
  // Open MPI's mpirun sets OMPI_COMM_WORLD_*; PMIx launchers (srun --mpi=pmix) PMIX_RANK;
  // MPICH's hydra PMI_RANK and PMI_SIZE
  for (const char* name : {"OMPI_COMM_WORLD_RANK", "PMIX_RANK", "PMI_RANK"})
    if (std::getenv(name)) {
      env.launched = true;
      env.rank = env_number(name, 0);
      break;
    }
  env.size = env_number("OMPI_COMM_WORLD_SIZE", env_number("PMI_SIZE", 0));
  if (std::getenv("OMPI_COMM_WORLD_SIZE")) env.launched = true;
  return env;
}

#if TETRA_HAVE_MPI

class MpiRanks final : public Ranks {
 public:
  MpiRanks() {
    int provided = 0;
    if (MPI_Init_thread(nullptr, nullptr, MPI_THREAD_FUNNELED, &provided) != MPI_SUCCESS) throw std::runtime_error("MPI_Init_thread failed");
    if (provided < MPI_THREAD_FUNNELED) {
      MPI_Finalize();
      throw std::runtime_error("this MPI library does not allow threads beside the one calling MPI (MPI_THREAD_FUNNELED)");
    }
    MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
    MPI_Comm_size(MPI_COMM_WORLD, &size_);
    MPI_Comm node;
    MPI_Comm_split_type(MPI_COMM_WORLD, MPI_COMM_TYPE_SHARED, rank_, MPI_INFO_NULL, &node);
    MPI_Comm_size(node, &node_size_);
    MPI_Comm_free(&node);
  }
  ~MpiRanks() override { MPI_Finalize(); }
  int rank() const override { return rank_; }
  int size() const override { return size_; }
  int node_size() const override { return node_size_; }

  std::vector<std::vector<uint8_t>> all_gather(std::span<const uint8_t> mine) override {
    wait_for_all();  // the ranks end their share of a level at different times
    uint64_t my_bytes = mine.size();
    std::vector<uint64_t> bytes(size_);
    MPI_Allgather(&my_bytes, 1, MPI_UINT64_T, bytes.data(), 1, MPI_UINT64_T, MPI_COMM_WORLD);
    // each rank's bytes broadcast from it, in pieces a count of int can hold (a level of a
    // large mesh passes 2 GiB)
    std::vector<std::vector<uint8_t>> out(size_);
    for (int r = 0; r < size_; ++r) {
      out[r].resize(bytes[r]);
      if (r == rank_) std::copy(mine.begin(), mine.end(), out[r].begin());
      pieces(bytes[r], [&](uint64_t at, int piece) { MPI_Bcast(out[r].data() + at, piece, MPI_BYTE, r, MPI_COMM_WORLD); });
    }
    return out;
  }

  std::vector<std::vector<uint8_t>> gather(std::span<const uint8_t> mine, int root) override {
    wait_for_all();
    uint64_t my_bytes = mine.size();
    std::vector<uint64_t> bytes(size_);
    MPI_Gather(&my_bytes, 1, MPI_UINT64_T, bytes.data(), 1, MPI_UINT64_T, root, MPI_COMM_WORLD);
    std::vector<std::vector<uint8_t>> out(size_);
    if (rank_ != root) {
      pieces(my_bytes, [&](uint64_t at, int piece) { MPI_Send(mine.data() + at, piece, MPI_BYTE, root, kGatherTag, MPI_COMM_WORLD); });
      return out;
    }
    for (int r = 0; r < size_; ++r) {
      if (r == root) {
        out[r].assign(mine.begin(), mine.end());
        continue;
      }
      out[r].resize(bytes[r]);
      pieces(bytes[r], [&](uint64_t at, int piece) { MPI_Recv(out[r].data() + at, piece, MPI_BYTE, r, kGatherTag, MPI_COMM_WORLD, MPI_STATUS_IGNORE); });
    }
    return out;
  }

  void barrier() override { wait_for_all(); }

  [[noreturn]] void abort(const std::string& message, int exit_code) override {
    std::fprintf(stderr, "%s\n", message.c_str());
    std::fflush(stderr);
    MPI_Abort(MPI_COMM_WORLD, exit_code);
    std::_Exit(exit_code);  // MPI_Abort does not return; in case it does
  }

 private:
  // fn(offset, count) over `size` bytes in pieces a count of int can hold (a level of a large
  // mesh passes 2 GiB)
  template <class Fn>
  static void pieces(uint64_t size, Fn&& fn) {
    for (uint64_t at = 0; at < size; at += kPieceBytes) fn(at, static_cast<int>(std::min<uint64_t>(kPieceBytes, size - at)));
  }
  // Waits for every rank, asleep: Open MPI's blocking collectives poll at full speed, which
  // takes a core from the ranks still simplifying when ranks share a node (or the node is
  // shared with other work).
  void wait_for_all() {
    MPI_Request request;
    MPI_Ibarrier(MPI_COMM_WORLD, &request);
    for (int done = 0;;) {
      MPI_Test(&request, &done, MPI_STATUS_IGNORE);
      if (done) return;
      std::this_thread::sleep_for(kIdlePoll);
    }
  }
  static constexpr uint64_t kPieceBytes = uint64_t{1} << 30;
  static constexpr int kGatherTag = 14;
  static constexpr std::chrono::milliseconds kIdlePoll{2};
  int rank_ = 0, size_ = 1, node_size_ = 1;
};

#endif

}  // namespace

bool mpi_available() { return TETRA_HAVE_MPI != 0; }

Ranks* launched_ranks() {
  const LaunchEnvironment env = launch_environment();
  if (!env.launched) return nullptr;
#if TETRA_HAVE_MPI
  static std::unique_ptr<MpiRanks> ranks = std::make_unique<MpiRanks>();  // MPI_Finalize at exit
  return ranks.get();
#else
  if (env.size > 1 || env.rank > 0)
    throw std::runtime_error("started by an MPI launcher on several ranks, but this tetrascope was built without MPI (install libopenmpi-dev and rebuild, "
                             "or run it without mpirun)");
  return nullptr;
#endif
}

}  // namespace tetrascope::lod
