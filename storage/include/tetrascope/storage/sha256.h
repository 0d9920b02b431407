// SHA-256 of a mesh file, for the source fingerprint in a store's manifest. The digest comes
// from OpenSSL's libcrypto (EVP): cryptography is not ours to maintain, and it is ~4x faster
// than a portable implementation.
#pragma once

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <future>
#include <string>

struct evp_md_ctx_st;

namespace tetrascope::storage {

class Sha256 {
 public:
  Sha256();
  ~Sha256();
  Sha256(const Sha256&) = delete;
  Sha256& operator=(const Sha256&) = delete;
  void update(const void* data, size_t bytes);
  std::array<uint8_t, 32> finish();
  static std::string hex(const std::array<uint8_t, 32>& digest);

 private:
  evp_md_ctx_st* context_ = nullptr;
};

// Hashes a file on a thread of its own while the caller reads the same file.
//
// The constructor opens the file without blocking (O_NONBLOCK: a FIFO with no writer does not
// hang it) and refuses anything but a regular file (a symlink to /dev/zero, a FIFO, a device)
// before a byte is hashed; it throws MeshError for those. get() waits for the lowercase hex
// digest and rethrows a read error. The destructor cancels an unfinished hash and joins, so a
// caller that fails early (a reader error) reports its own error at once instead of waiting
// for gigabytes to be hashed.
class FileHasher {
 public:
  explicit FileHasher(const std::filesystem::path& path);
  ~FileHasher();
  FileHasher(const FileHasher&) = delete;
  FileHasher& operator=(const FileHasher&) = delete;
  std::string get();

 private:
  std::string hash(int fd, std::filesystem::path path);
  std::atomic<bool> cancelled_{false};
  std::future<std::string> digest_;
};

// Lowercase hex digest of a regular file's bytes; throws MeshError when it is not a regular
// file and std::runtime_error when it cannot be read.
std::string sha256_file(const std::filesystem::path& path);

}  // namespace tetrascope::storage
