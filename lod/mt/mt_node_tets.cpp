// Where `tetrascope preprocess` keeps the tets of its segments (mt_stages.h, NodeTets): a
// level that fits the memory budget in memory, a larger one in a spill file that has no name
// (unlinked as soon as it is made), so that a build that fails or is killed leaves nothing.
#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <string>

#include "mt_stages.h"

namespace tetrascope::lod::mt {
namespace {

[[noreturn]] void spill_error(const std::filesystem::path& directory, const char* what) {
  throw std::runtime_error("preprocess: spill file in " + directory.string() + ": " + what + ": " + std::strerror(errno));
}

// All `left` bytes between `p` and the file at `at`, by ::pread or ::pwrite, however many calls
// that takes.
template <class Io, class Pointer>
void whole(Io io, int fd, Pointer p, uint64_t at, uint64_t left, const std::filesystem::path& directory, const char* failure) {
  while (left > 0) {
    const ssize_t done = io(fd, p, left, static_cast<off_t>(at));
    if (done < 0 && errno == EINTR) continue;
    if (done <= 0) spill_error(directory, failure);
    p += done;
    at += static_cast<uint64_t>(done);
    left -= static_cast<uint64_t>(done);
  }
}

}  // namespace

NodeTets::NodeTets(std::filesystem::path directory) : directory_(std::move(directory)) {}

NodeTets::NodeTets(NodeTets&& other) noexcept
    : nodes_(std::move(other.nodes_)), directory_(std::move(other.directory_)), fd_(other.fd_), end_(other.end_), spilled_peak_(other.spilled_peak_) {
  other.fd_ = -1;
}

NodeTets& NodeTets::operator=(NodeTets&& other) noexcept {
  if (this != &other) {
    if (fd_ >= 0) ::close(fd_);
    nodes_ = std::move(other.nodes_);
    directory_ = std::move(other.directory_);
    fd_ = other.fd_;
    end_ = other.end_;
    spilled_peak_ = other.spilled_peak_;
    other.fd_ = -1;
  }
  return *this;
}

NodeTets::~NodeTets() {
  if (fd_ >= 0) ::close(fd_);
}

void NodeTets::open_spill() {
  if (fd_ >= 0) return;
  const std::filesystem::path dir = directory_.empty() ? std::filesystem::path(".") : directory_;
  std::string name = (dir / ".tetrascope-spill-XXXXXX").string();
  fd_ = ::mkstemp(name.data());
  if (fd_ < 0) spill_error(dir, "cannot create");
  ::unlink(name.c_str());  // no name: the file goes when the build ends, however it ends
}

uint32_t NodeTets::add(uint32_t level, uint64_t tets, bool spill) {
  Node node;
  node.level = level;
  node.tets = tets;
  node.spilled = spill;
  if (spill) {
    open_spill();
    node.offset = end_;
    end_ += 16 * tets;
    spilled_peak_ = std::max(spilled_peak_, end_);
  } else {
    node.ids.resize(4 * tets);
  }
  nodes_.push_back(std::move(node));
  return static_cast<uint32_t>(nodes_.size() - 1);
}

uint32_t NodeTets::add(uint32_t level, std::vector<uint32_t> ids, bool spill) {
  if (!spill) {
    Node node;
    node.level = level;
    node.tets = ids.size() / 4;
    node.ids = std::move(ids);
    nodes_.push_back(std::move(node));
    return static_cast<uint32_t>(nodes_.size() - 1);
  }
  const uint32_t n = add(level, ids.size() / 4, true);
  write(n, 0, ids);
  return n;
}

void NodeTets::append(std::span<const uint32_t> ids) {
  Node& node = nodes_.back();
  const uint64_t begin = node.tets;
  node.tets += ids.size() / 4;
  if (!node.spilled) {
    node.ids.insert(node.ids.end(), ids.begin(), ids.end());
    return;
  }
  if (node.offset + 16 * begin != end_) throw std::logic_error("NodeTets::append: not the last spilled node");
  end_ += 16 * (ids.size() / 4);
  spilled_peak_ = std::max(spilled_peak_, end_);
  write(static_cast<uint32_t>(nodes_.size() - 1), begin, ids);
}

std::span<const uint32_t> NodeTets::read(uint32_t n, uint64_t begin, uint64_t count, std::vector<uint32_t>& buffer) const {
  const Node& node = nodes_[n];
  if (begin + count > node.tets) throw std::logic_error("NodeTets::read: past the node's tets");
  if (!node.spilled) return std::span<const uint32_t>(node.ids).subspan(4 * begin, 4 * count);
  buffer.resize(4 * count);
  whole(::pread, fd_, reinterpret_cast<char*>(buffer.data()), node.offset + 16 * begin, 16 * count, directory_, "read failed");
  return buffer;
}

void NodeTets::write(uint32_t n, uint64_t begin, std::span<const uint32_t> ids) {
  Node& node = nodes_[n];
  if (begin + ids.size() / 4 > node.tets) throw std::logic_error("NodeTets::write: past the node's tets");
  if (!node.spilled) {
    std::copy(ids.begin(), ids.end(), node.ids.begin() + static_cast<std::ptrdiff_t>(4 * begin));
    return;
  }
  whole(::pwrite, fd_, reinterpret_cast<const char*>(ids.data()), node.offset + 16 * begin, 4 * ids.size(), directory_, "write failed (is the disk full?)");
}

}  // namespace tetrascope::lod::mt
