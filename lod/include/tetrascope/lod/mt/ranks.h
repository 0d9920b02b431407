// The processes of one MPI launch (`mpirun -np N tetrascope preprocess …`) that
// share the work of a preprocess: every rank reads the mesh and builds the same partitions,
// each simplifies its share of a level's segments, and the results are exchanged so that every
// rank goes on with the same state; rank 0 writes the store.
//
// The one seam over MPI (ranks.cpp): a build without MPI (TETRA_MPI=OFF, or Open MPI not
// found) has the same interface and never has more than one rank. MPI is initialised only
// when the process was started by an MPI launcher, so the ordinary CLI, the server and the
// tests never touch it.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace tetrascope::lod {

class Ranks {
 public:
  virtual ~Ranks() = default;
  virtual int rank() const = 0;
  virtual int size() const = 0;
  // The ranks on this rank's node (sharing its memory and cores), this one among them.
  virtual int node_size() const = 0;
  // Every rank's bytes, in rank order (`mine` among them). Collective: every rank calls it,
  // in the same order of calls.
  virtual std::vector<std::vector<uint8_t>> all_gather(std::span<const uint8_t> mine) = 0;
  // Every rank's bytes on `root`, in rank order (`mine` among them); on the other ranks
  // size() empty vectors. Collective, as all_gather.
  virtual std::vector<std::vector<uint8_t>> gather(std::span<const uint8_t> mine, int root) = 0;
  // Waits for every rank. Collective.
  virtual void barrier() = 0;
  // Ends every rank of the launch with `exit_code`, after writing `message` to stderr: an
  // error on one rank must not leave the others waiting in a collective.
  [[noreturn]] virtual void abort(const std::string& message, int exit_code) = 0;
};

// Whether this build can run on several ranks (built with MPI).
bool mpi_available();

// The launch this process belongs to, or nullptr when it was not started by an MPI launcher
// (no OMPI_COMM_WORLD_SIZE, PMIX_RANK or PMI_RANK in the environment). Initialises MPI on
// the first call; MPI is finalised at exit. Throws std::runtime_error when launched on more
// than one rank by a build without MPI (each rank would build and write the whole store).
Ranks* launched_ranks();

}  // namespace tetrascope::lod
