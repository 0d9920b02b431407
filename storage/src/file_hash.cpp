// SHA-256 through OpenSSL's EVP interface, and a cancellable file hasher.
#include "tetrascope/storage/sha256.h"

#include <fcntl.h>
#include <openssl/evp.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <vector>

#include "tetrascope/storage/mesh_error.h"

namespace tetrascope::storage {

Sha256::Sha256() : context_(EVP_MD_CTX_new()) {
  if (!context_ || EVP_DigestInit_ex(context_, EVP_sha256(), nullptr) != 1) {
    EVP_MD_CTX_free(context_);
    throw std::runtime_error("OpenSSL: SHA-256 is not available");
  }
}

Sha256::~Sha256() { EVP_MD_CTX_free(context_); }

void Sha256::update(const void* data, size_t bytes) {
  if (bytes > 0 && EVP_DigestUpdate(context_, data, bytes) != 1) throw std::runtime_error("OpenSSL: SHA-256 update failed");
}

std::array<uint8_t, 32> Sha256::finish() {
  std::array<uint8_t, 32> digest{};
  unsigned int length = 0;
  if (EVP_DigestFinal_ex(context_, digest.data(), &length) != 1 || length != digest.size()) {
    throw std::runtime_error("OpenSSL: SHA-256 final failed");
  }
  return digest;
}

std::string Sha256::hex(const std::array<uint8_t, 32>& digest) {
  static constexpr char kDigits[] = "0123456789abcdef";
  std::string s;
  s.reserve(64);
  for (uint8_t v : digest) {
    s += kDigits[v >> 4];
    s += kDigits[v & 15];
  }
  return s;
}

FileHasher::FileHasher(const std::filesystem::path& path) {
  int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK | O_NOCTTY);
  if (fd < 0) throw MeshError(path.string() + ": cannot open: " + std::strerror(errno));
  struct stat st {};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd);
    throw MeshError(path.string() + ": not a regular file");
  }
  ::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL) & ~O_NONBLOCK);
  digest_ = std::async(std::launch::async, [this, fd, path] { return hash(fd, path); });
}

FileHasher::~FileHasher() {
  cancelled_ = true;
  if (digest_.valid()) digest_.wait();
}

std::string FileHasher::get() { return digest_.get(); }

std::string FileHasher::hash(int fd, std::filesystem::path path) {
  struct Closer {
    int fd;
    ~Closer() { ::close(fd); }
  } closer{fd};
  Sha256 sha;
  std::vector<char> buffer(1 << 20);
  while (!cancelled_) {
    ssize_t got = ::read(fd, buffer.data(), buffer.size());
    if (got < 0 && errno == EINTR) continue;
    if (got < 0) throw std::runtime_error(path.string() + ": read error while hashing: " + std::strerror(errno));
    if (got == 0) return Sha256::hex(sha.finish());
    sha.update(buffer.data(), static_cast<size_t>(got));
  }
  return {};
}

std::string sha256_file(const std::filesystem::path& path) { return FileHasher(path).get(); }

}  // namespace tetrascope::storage
