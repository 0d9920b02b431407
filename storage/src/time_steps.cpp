#include "tetrascope/storage/time_steps.h"

#include <fcntl.h>
#include <libdeflate.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <stdexcept>

namespace tetrascope::storage {
namespace {

// steps.bin's header: 64 bytes, the CRC-32 over the first 60.
struct StepsHeader {
  char magic[8];
  uint32_t version;
  uint32_t steps;  // with step 0; blocks = steps - 1
  uint32_t floats;
  uint32_t reserved;
  uint64_t input_vertices, store_vertices, collapses;
  uint64_t reserved2;
  uint32_t index_crc;
  uint32_t header_crc;
};
static_assert(sizeof(StepsHeader) == 64);
// One index entry a block: 32 bytes.
struct StepsEntry {
  uint64_t offset, bytes;
  uint32_t crc, values_crc;
  uint64_t reserved;
};
static_assert(sizeof(StepsEntry) == 32);
constexpr char kMagic[8] = {'T', 'S', 'S', 'T', 'E', 'P', 'S', '1'};
constexpr uint32_t kVersion = 1;
constexpr size_t kKeptSteps = 3;  // the step shown, the one before and the next (prefetched)

[[noreturn]] void fail(const std::filesystem::path& path, const std::string& what) { throw TimeStepsError(path.string() + ": " + what); }

// The bytes of the floats grouped by position (every first byte, then every second, ...):
// neighbouring values share their high bytes, which deflate then finds.
std::vector<unsigned char> shuffle(std::span<const float> values) {
  std::vector<unsigned char> out(values.size() * 4);
  const auto* in = reinterpret_cast<const unsigned char*>(values.data());
  for (size_t i = 0; i < values.size(); ++i)
    for (size_t b = 0; b < 4; ++b) out[b * values.size() + i] = in[4 * i + b];
  return out;
}

void unshuffle(const std::vector<unsigned char>& bytes, std::vector<float>& values) {
  auto* out = reinterpret_cast<unsigned char*>(values.data());
  const size_t n = values.size();
  for (size_t i = 0; i < n; ++i)
    for (size_t b = 0; b < 4; ++b) out[4 * i + b] = bytes[b * n + i];
}

void pwrite_all(int fd, const std::filesystem::path& path, const void* data, size_t bytes, uint64_t offset) {
  size_t done = 0;
  while (done < bytes) {
    const ssize_t wrote = ::pwrite(fd, static_cast<const char*>(data) + done, bytes - done, static_cast<off_t>(offset + done));
    if (wrote < 0 && errno == EINTR) continue;
    if (wrote <= 0) throw std::runtime_error(path.string() + ": write failed: " + std::strerror(errno));
    done += static_cast<size_t>(wrote);
  }
}

void pread_all(int fd, const std::filesystem::path& path, void* data, size_t bytes, uint64_t offset) {
  size_t done = 0;
  while (done < bytes) {
    const ssize_t got = ::pread(fd, static_cast<char*>(data) + done, bytes - done, static_cast<off_t>(offset + done));
    if (got < 0 && errno == EINTR) continue;
    if (got <= 0) fail(path, "truncated at byte " + std::to_string(offset + done));
    done += static_cast<size_t>(got);
  }
}

double value_scalar(const float* v, uint32_t components) {
  if (components == 1) return v[0];
  double sum = 0;
  for (uint32_t k = 0; k < components; ++k) sum += double(v[k]) * v[k];
  return std::sqrt(sum);
}

}  // namespace

std::vector<TimeStep> manifest_time_steps(const StoreManifest& manifest) {
  std::vector<TimeStep> out;
  if (!manifest.json.contains("time_steps")) return out;
  const std::string where = "manifest.json: time_steps: ";
  try {
    const auto& list = manifest.json.at("time_steps").at("steps");
    if (!list.is_array() || list.size() < 2 || list.size() > kMaxTimeSteps) throw TimeStepsError(where + "2 to " + std::to_string(kMaxTimeSteps) + " steps expected");
    for (const auto& s : list) {
      TimeStep step;
      step.index = s.at("index").get<uint32_t>();
      step.time = s.at("time").get<double>();
      step.name = s.at("name").get<std::string>();
      for (const auto& r : s.at("ranges")) step.ranges.push_back({r.at(0).get<double>(), r.at(1).get<double>()});
      if (step.index != out.size()) throw TimeStepsError(where + "step " + std::to_string(out.size()) + " has index " + std::to_string(step.index));
      if (!std::isfinite(step.time) || (!out.empty() && !(step.time > out.back().time)))
        throw TimeStepsError(where + "step " + std::to_string(step.index) + ": its time is not finite or not after the step before");
      if (step.ranges.size() != manifest.attributes.size()) throw TimeStepsError(where + "step " + std::to_string(step.index) + ": a range per attribute expected");
      out.push_back(std::move(step));
    }
  } catch (const nlohmann::json::exception& e) {
    throw TimeStepsError(where + "malformed (" + e.what() + ")");
  }
  return out;
}

std::array<double, 2> series_range(const StoreManifest& manifest, size_t attribute) {
  const StoreAttribute& a = manifest.attributes.at(attribute);
  std::array<double, 2> r{a.min, a.max};
  std::vector<TimeStep> steps;
  try {
    steps = manifest_time_steps(manifest);
  } catch (const TimeStepsError&) {
    return r;  // damage is reported where the steps are opened
  }
  for (const TimeStep& s : steps) {
    r[0] = std::min(r[0], s.ranges[attribute][0]);
    r[1] = std::max(r[1], s.ranges[attribute][1]);
  }
  return r;
}

nlohmann::json time_steps_manifest(const std::vector<TimeStep>& steps, const StepLayout& layout, uint64_t bytes) {
  nlohmann::json list = nlohmann::json::array();
  for (const TimeStep& s : steps) {
    nlohmann::json ranges = nlohmann::json::array();
    for (const auto& r : s.ranges) ranges.push_back({r[0], r[1]});
    list.push_back({{"index", s.index}, {"time", s.time}, {"name", s.name}, {"ranges", ranges}});
  }
  return {{"file", kTimeStepsFile}, {"bytes", bytes}, {"count", steps.size()}, {"collapses", layout.collapses}, {"steps", list}};
}

TimeStepsWriter::TimeStepsWriter(std::filesystem::path path, const StepLayout& layout, uint32_t steps) : path_(std::move(path)), layout_(layout), steps_(steps) {
  if (steps < 2 || steps > kMaxTimeSteps) throw std::invalid_argument("a time series has 2 to " + std::to_string(kMaxTimeSteps) + " steps");
  fd_ = ::open(path_.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd_ < 0) throw std::runtime_error(path_.string() + ": cannot create: " + std::strerror(errno));
  end_ = sizeof(StepsHeader) + sizeof(StepsEntry) * (steps - 1);
  index_.resize(sizeof(StepsEntry) * (steps - 1), 0);
}

TimeStepsWriter::~TimeStepsWriter() {
  if (fd_ >= 0) ::close(fd_);
}

void TimeStepsWriter::add(std::span<const float> values) {
  if (added_ + 1 >= steps_) throw std::logic_error("steps.bin: more steps added than declared");
  if (values.size() != layout_.rows() * layout_.floats) throw std::logic_error("steps.bin: a step of the wrong size");
  const std::vector<unsigned char> shuffled = shuffle(values);
  libdeflate_compressor* c = libdeflate_alloc_compressor(6);
  if (!c) throw std::bad_alloc();
  std::vector<unsigned char> packed(libdeflate_deflate_compress_bound(c, shuffled.size()));
  const size_t bytes = libdeflate_deflate_compress(c, shuffled.data(), shuffled.size(), packed.data(), packed.size());
  libdeflate_free_compressor(c);
  if (bytes == 0) throw std::runtime_error(path_.string() + ": compression failed");
  pwrite_all(fd_, path_, packed.data(), bytes, end_);
  StepsEntry e{end_, bytes, crc32_of(packed.data(), bytes), crc32_of(values.data(), values.size() * sizeof(float)), 0};
  std::memcpy(index_.data() + sizeof(StepsEntry) * added_, &e, sizeof e);
  end_ += bytes;
  ++added_;
}

uint64_t TimeStepsWriter::finish() {
  if (added_ + 1 != steps_) throw std::logic_error("steps.bin: fewer steps added than declared");
  StepsHeader h{};
  std::memcpy(h.magic, kMagic, sizeof kMagic);
  h.version = kVersion;
  h.steps = steps_;
  h.floats = layout_.floats;
  h.input_vertices = layout_.input_vertices;
  h.store_vertices = layout_.store_vertices;
  h.collapses = layout_.collapses;
  h.index_crc = crc32_of(index_.data(), index_.size());
  h.header_crc = crc32_of(&h, offsetof(StepsHeader, header_crc));
  pwrite_all(fd_, path_, index_.data(), index_.size(), sizeof h);
  pwrite_all(fd_, path_, &h, sizeof h, 0);
  if (::fsync(fd_) != 0 || ::close(fd_) != 0) {
    fd_ = -1;
    throw std::runtime_error(path_.string() + ": write failed: " + std::strerror(errno));
  }
  fd_ = -1;
  return end_;
}

std::shared_ptr<const TimeSteps> TimeSteps::open(const Store& store) {
  std::vector<TimeStep> steps = manifest_time_steps(store.manifest());
  if (steps.empty()) return nullptr;
  std::shared_ptr<TimeSteps> t(new TimeSteps());
  t->steps_ = std::move(steps);
  t->path_ = store.path() / kTimeStepsFile;
  t->fd_ = ::open(t->path_.c_str(), O_RDONLY | O_CLOEXEC);
  if (t->fd_ < 0) fail(t->path_, std::string("cannot open (") + std::strerror(errno) + "); the manifest lists " + std::to_string(t->steps_.size()) + " time steps");
  const off_t size = ::lseek(t->fd_, 0, SEEK_END);
  if (size < off_t(sizeof(StepsHeader))) fail(t->path_, "shorter than its header");
  t->file_bytes_ = static_cast<uint64_t>(size);
  StepsHeader h{};
  pread_all(t->fd_, t->path_, &h, sizeof h, 0);
  if (std::memcmp(h.magic, kMagic, sizeof kMagic) != 0) fail(t->path_, "not a steps file (bad magic)");
  if (crc32_of(&h, offsetof(StepsHeader, header_crc)) != h.header_crc) fail(t->path_, "header: checksum mismatch");
  if (h.version != kVersion) fail(t->path_, "format version " + std::to_string(h.version) + ", this build reads " + std::to_string(kVersion));
  if (h.steps != t->steps_.size()) fail(t->path_, std::to_string(h.steps) + " steps, the manifest lists " + std::to_string(t->steps_.size()));
  uint32_t floats = 0;
  for (const auto& a : store.manifest().attributes) floats += a.components;
  if (h.floats != floats) fail(t->path_, std::to_string(h.floats) + " values a vertex, the store has " + std::to_string(floats));
  const uint64_t stored = store.manifest().vertex_count;
  const auto& mr = store.manifest().json.value("multiresolution", nlohmann::json::object());
  const uint64_t input = mr.contains("input") ? mr["input"].value("vertices", stored) : stored;
  if (h.store_vertices != stored || h.input_vertices != input || h.collapses > (uint64_t{1} << 32))
    fail(t->path_, "vertex counts (" + std::to_string(h.input_vertices) + " input, " + std::to_string(h.store_vertices) + " stored) differ from the store's (" + std::to_string(input) + ", " + std::to_string(stored) + ")");
  t->layout_ = {h.input_vertices, h.store_vertices, h.collapses, h.floats};
  std::vector<StepsEntry> entries(h.steps - 1);
  if (t->file_bytes_ < sizeof h + entries.size() * sizeof(StepsEntry)) fail(t->path_, "index: file truncated");
  pread_all(t->fd_, t->path_, entries.data(), entries.size() * sizeof(StepsEntry), sizeof h);
  if (crc32_of(entries.data(), entries.size() * sizeof(StepsEntry)) != h.index_crc) fail(t->path_, "index: checksum mismatch");
  const uint64_t raw = t->layout_.rows() * t->layout_.floats * sizeof(float);
  for (size_t i = 0; i < entries.size(); ++i) {
    const StepsEntry& e = entries[i];
    if (e.offset < sizeof h + entries.size() * sizeof(StepsEntry) || e.bytes == 0 || e.offset > t->file_bytes_ || e.bytes > t->file_bytes_ - e.offset)
      fail(t->path_, "step " + std::to_string(i + 1) + ": block outside the file");
    // deflate expands at most about 1032:1; a block claiming more is damage, not data
    if (raw / 1032 > e.bytes) fail(t->path_, "step " + std::to_string(i + 1) + ": block too short for its values");
    t->blocks_.push_back({e.offset, e.bytes, e.crc, e.values_crc});
  }
  return t;
}

TimeSteps::~TimeSteps() {
  if (fd_ >= 0) ::close(fd_);
}

uint32_t TimeSteps::step_at_time(double time) const {
  uint32_t best = 0;
  for (uint32_t i = 1; i < steps_.size(); ++i)
    if (std::abs(steps_[i].time - time) < std::abs(steps_[best].time - time)) best = i;
  return best;
}

std::shared_ptr<const std::vector<float>> TimeSteps::values(uint32_t step) const {
  if (step >= steps_.size()) throw std::out_of_range("no time step " + std::to_string(step) + " (the dataset has " + std::to_string(steps_.size()) + ")");
  if (step == 0) return nullptr;
  {
    std::lock_guard lock(mutex_);
    for (auto it = recent_.begin(); it != recent_.end(); ++it)
      if (it->first == step) {
        recent_.splice(recent_.begin(), recent_, it);
        return recent_.front().second;
      }
  }
  const Block& b = blocks_[step - 1];
  const std::string where = "step " + std::to_string(step) + ": ";
  std::vector<unsigned char> packed(b.bytes);
  pread_all(fd_, path_, packed.data(), packed.size(), b.offset);
  if (crc32_of(packed.data(), packed.size()) != b.crc) fail(path_, where + "block checksum mismatch");
  auto values = std::make_shared<std::vector<float>>(layout_.rows() * layout_.floats);
  std::vector<unsigned char> shuffled(values->size() * sizeof(float));
  libdeflate_decompressor* d = libdeflate_alloc_decompressor();
  if (!d) throw std::bad_alloc();
  size_t got = 0;
  const libdeflate_result r = libdeflate_deflate_decompress(d, packed.data(), packed.size(), shuffled.data(), shuffled.size(), &got);
  libdeflate_free_decompressor(d);
  if (r != LIBDEFLATE_SUCCESS || got != shuffled.size()) fail(path_, where + "block does not inflate to its values");
  unshuffle(shuffled, *values);
  if (crc32_of(values->data(), values->size() * sizeof(float)) != b.values_crc) fail(path_, where + "values checksum mismatch");
  for (size_t i = 0; i < values->size(); ++i)
    if (!std::isfinite((*values)[i])) fail(path_, where + "value " + std::to_string(i) + " is not finite");
  std::lock_guard lock(mutex_);
  recent_.emplace_front(step, values);
  if (recent_.size() > kKeptSteps) recent_.pop_back();
  return values;
}

std::shared_ptr<const MappedSegment> with_step_values(std::shared_ptr<const MappedSegment> segment, const StoreManifest& manifest, const StepLayout& layout,
                                                      const std::vector<float>& values) {
  const SegmentView& s = segment->view();
  std::vector<float> out(s.attributes.size());
  size_t offset = 0;  // floats into a row before the attribute
  for (const StoreAttribute& a : manifest.attributes) {
    float* dst = out.data() + size_t{s.vertex_count} * offset;
    for (uint32_t l = 0; l < s.vertex_count; ++l) {
      const uint64_t row = layout.row_of_store_vertex(s.global_ids[l]);
      if (row >= layout.rows()) throw TimeStepsError("segment " + std::to_string(s.id) + ": vertex id " + std::to_string(s.global_ids[l]) + " beyond the time step's values");
      std::copy_n(values.data() + row * layout.floats + offset, a.components, dst + size_t{l} * a.components);
    }
    offset += a.components;
  }
  return std::make_shared<const MappedSegment>(std::move(segment), std::move(out));
}

std::vector<std::string> verify_time_steps(const Store& store) {
  std::vector<std::string> problems;
  try {
    const auto steps = TimeSteps::open(store);
    if (!steps) return problems;
    const auto& attributes = store.manifest().attributes;
    for (uint32_t i = 1; i < steps->count(); ++i) {
      const auto values = steps->values(i);
      const StepLayout& l = steps->layout();
      for (size_t a = 0, offset = 0; a < attributes.size(); offset += attributes[a].components, ++a) {
        double lo = INFINITY, hi = -INFINITY;
        for (uint64_t v = 0; v < l.input_vertices; ++v) {
          const double x = value_scalar(values->data() + v * l.floats + offset, attributes[a].components);
          lo = std::min(lo, x);
          hi = std::max(hi, x);
        }
        const auto& r = steps->steps()[i].ranges[a];
        const double tolerance = 1e-5 * std::max({1.0, std::abs(lo), std::abs(hi)});
        if (l.input_vertices > 0 && (std::abs(lo - r[0]) > tolerance || std::abs(hi - r[1]) > tolerance))
          problems.push_back(std::string(kTimeStepsFile) + ": step " + std::to_string(i) + ": attribute '" + attributes[a].name + "' ranges over [" + std::to_string(lo) + ", " +
                             std::to_string(hi) + "], the manifest says [" + std::to_string(r[0]) + ", " + std::to_string(r[1]) + "]");
      }
    }
  } catch (const std::exception& e) {
    problems.push_back(e.what());
  }
  return problems;
}

}  // namespace tetrascope::storage
