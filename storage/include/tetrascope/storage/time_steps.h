// steps.bin: the values of a time series' further steps in a store. The mesh, the levels and
// the DAG are built once, from step 0, whose values the segments and vertices.bin hold as
// for any store; each further step keeps the values at every stored vertex, one block a
// step, compressed (deflate) and checksummed. Layout and checks: docs/store-format.md.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <list>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "tetrascope/storage/store.h"

namespace tetrascope::storage {

inline constexpr const char* kTimeStepsFile = "steps.bin";
inline constexpr uint32_t kMaxTimeSteps = 100000;

// steps.bin or the manifest's time_steps entry fails its checks (damage).
class TimeStepsError : public StoreError {
 public:
  using StoreError::StoreError;
};

// One step as the manifest lists it: its index (0 = the values the segments hold), its time
// value, a name (the file or folder it came from) and per attribute the range of its value
// (a vector's magnitude) over the input's vertices.
struct TimeStep {
  uint32_t index = 0;
  double time = 0;
  std::string name;
  std::vector<std::array<double, 2>> ranges;
};

// The steps the manifest lists; empty for a store of one step. Throws TimeStepsError for a
// malformed entry.
std::vector<TimeStep> manifest_time_steps(const StoreManifest& manifest);
// The range of attribute `attribute` over every step of a series (its own range without one):
// the colour range that stays put while the steps play.
std::array<double, 2> series_range(const StoreManifest& manifest, size_t attribute);

// Where a stored vertex's values sit in a step's block: the input's vertices (store ids
// 0..V-1) first, then vertices.bin's collapsed vertices (C of them), then the store's other
// vertices (ids V..N-1). Rows of `floats` values (the attributes' components in manifest
// order), as vertices.bin keeps them.
struct StepLayout {
  uint64_t input_vertices = 0;  // V
  uint64_t store_vertices = 0;  // N
  uint64_t collapses = 0;       // C
  uint32_t floats = 0;
  uint64_t rows() const { return store_vertices + collapses; }
  uint64_t row_of_store_vertex(uint64_t id) const { return id < input_vertices ? id : id + collapses; }
};

// Writes steps.bin: `steps` - 1 blocks (steps 1 ..), each added in order. The file is complete
// once finish() returned; it lies inside a store being written (renamed when complete).
class TimeStepsWriter {
 public:
  TimeStepsWriter(std::filesystem::path path, const StepLayout& layout, uint32_t steps);
  ~TimeStepsWriter();
  TimeStepsWriter(const TimeStepsWriter&) = delete;
  TimeStepsWriter& operator=(const TimeStepsWriter&) = delete;
  void add(std::span<const float> values);  // layout.rows() × floats values of the next step
  uint64_t finish();                         // the file's bytes

 private:
  std::filesystem::path path_;
  StepLayout layout_;
  uint32_t steps_;
  int fd_ = -1;
  uint64_t end_ = 0;
  std::vector<unsigned char> index_;
  uint32_t added_ = 0;
};

// The manifest's time_steps entry for a series of `steps` written to a file of `bytes`.
nlohmann::json time_steps_manifest(const std::vector<TimeStep>& steps, const StepLayout& layout, uint64_t bytes);

// A store's steps: the manifest's list and steps.bin's header and index, checked on open; a
// step's block inflated and checked (both checksums, every value finite) when first asked for.
// Thread-safe.
class TimeSteps {
 public:
  // null when the store has no series. Throws TimeStepsError.
  static std::shared_ptr<const TimeSteps> open(const Store& store);
  ~TimeSteps();
  TimeSteps(const TimeSteps&) = delete;
  TimeSteps& operator=(const TimeSteps&) = delete;

  uint32_t count() const { return static_cast<uint32_t>(steps_.size()); }
  const std::vector<TimeStep>& steps() const { return steps_; }
  const StepLayout& layout() const { return layout_; }
  // The step whose time is nearest `time` (the earlier on a tie).
  uint32_t step_at_time(double time) const;
  // Step `step`'s values (layout().rows() × floats); null for step 0, whose values are the
  // store's own. The last few steps asked for are kept. Throws TimeStepsError (damage) or
  // std::out_of_range (no such step).
  std::shared_ptr<const std::vector<float>> values(uint32_t step) const;

 private:
  TimeSteps() = default;
  std::filesystem::path path_;
  int fd_ = -1;
  uint64_t file_bytes_ = 0;
  StepLayout layout_;
  std::vector<TimeStep> steps_;
  struct Block {
    uint64_t offset = 0, bytes = 0;
    uint32_t crc = 0, values_crc = 0;
  };
  std::vector<Block> blocks_;  // steps 1..
  mutable std::mutex mutex_;
  mutable std::list<std::pair<uint32_t, std::shared_ptr<const std::vector<float>>>> recent_;
};

// A mapped segment with its attributes replaced by a step's values (by its vertices' global
// ids); the segment's own mapping is kept by it.
std::shared_ptr<const MappedSegment> with_step_values(std::shared_ptr<const MappedSegment> segment, const StoreManifest& manifest, const StepLayout& layout,
                                                      const std::vector<float>& values);

// What `tetrascope verify` reports for a store's steps (empty: sound, or no series): the
// manifest's entry, steps.bin's header and index, every block inflated and checked, and each
// step's ranges equal to those of its values.
std::vector<std::string> verify_time_steps(const Store& store);

}  // namespace tetrascope::storage
