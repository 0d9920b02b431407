#include "input.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <charconv>
#include <cstring>

namespace tetrascope::storage::detail {

std::shared_ptr<InputFile> InputFile::open(const std::filesystem::path& path, const ReadLimits& limits) {
  std::shared_ptr<InputFile> file(new InputFile());
  file->name_ = path.filename().string();
  file->limits_ = limits;
  file->fd_ = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK | O_NOCTTY);
  if (file->fd_ < 0) {
    throw MeshError(path.string() + ": cannot open: " + std::strerror(errno));
  }
  struct stat st {};
  if (::fstat(file->fd_, &st) != 0 || !S_ISREG(st.st_mode)) {
    throw MeshError(path.string() + ": not a regular file");
  }
  // Reads of a regular file never block; clear the flag so nothing depends on it.
  ::fcntl(file->fd_, F_SETFL, ::fcntl(file->fd_, F_GETFL) & ~O_NONBLOCK);
  file->size_ = static_cast<uint64_t>(st.st_size);
#ifdef POSIX_FADV_SEQUENTIAL
  ::posix_fadvise(file->fd_, 0, 0, POSIX_FADV_SEQUENTIAL);
#endif
  return file;
}

std::shared_ptr<InputFile> InputFile::from_memory(std::string name, std::span<const char> bytes, const ReadLimits& limits) {
  std::shared_ptr<InputFile> file(new InputFile());
  file->limits_ = limits;
  file->name_ = std::move(name);
  file->memory_.assign(bytes.begin(), bytes.end());
  file->size_ = bytes.size();
  return file;
}

InputFile::~InputFile() {
  if (fd_ >= 0) ::close(fd_);
}

size_t InputFile::read_at(uint64_t offset, void* dst, size_t n) const {
  if (offset >= size_) return 0;
  if (n > size_ - offset) n = static_cast<size_t>(size_ - offset);
  if (fd_ < 0) {
    std::memcpy(dst, memory_.data() + offset, n);
    return n;
  }
  size_t done = 0;
  while (done < n) {
    ssize_t got = ::pread(fd_, static_cast<char*>(dst) + done, n - done,
                          static_cast<off_t>(offset + done));
    if (got < 0) {
      if (errno == EINTR) continue;
      fail_at_byte(offset + done, std::string("read error: ") + std::strerror(errno));
    }
    if (got == 0) break;
    done += static_cast<size_t>(got);
  }
  return done;
}

void InputFile::fail_at_byte(uint64_t offset, std::string_view what) const {
  throw MeshError(name_ + ": byte " + std::to_string(offset) + ": " + std::string(what));
}

Cursor::Cursor(std::shared_ptr<const InputFile> file, uint64_t offset, uint64_t line)
    : file_(std::move(file)), buffer_(kBufferBytes) {
  seek(offset, line);
}

void Cursor::seek(uint64_t offset, uint64_t line) {
  buffer_start_ = offset;
  pos_ = end_ = 0;
  line_ = line;
}

bool Cursor::fill(size_t keep_from) {
  // Keep bytes [keep_from, end_) and append more after them.
  size_t keep = end_ - keep_from;
  if (keep_from > 0 && keep > 0) std::memmove(buffer_.data(), buffer_.data() + keep_from, keep);
  buffer_start_ += keep_from;
  pos_ -= keep_from;
  end_ = keep;
  size_t got = file_->read_at(buffer_start_ + end_, buffer_.data() + end_, buffer_.size() - end_);
  end_ += got;
  return got > 0;
}

void Cursor::skip_whitespace() {
  for (;;) {
    while (pos_ < end_) {
      char c = buffer_[pos_];
      if (c == '\n') {
        ++line_;
      } else if (c != ' ' && c != '\t' && c != '\r' && c != '\f' && c != '\v') {
        return;
      }
      ++pos_;
    }
    if (!fill(pos_)) return;
  }
}

bool Cursor::at_end() {
  if (pos_ < end_) return false;
  return !fill(pos_);
}

int Cursor::peek() {
  if (pos_ >= end_ && !fill(pos_)) return -1;
  return static_cast<unsigned char>(buffer_[pos_]);
}

int Cursor::get() {
  int c = peek();
  if (c >= 0) {
    ++pos_;
    if (c == '\n') ++line_;
  }
  return c;
}

bool Cursor::skip_until(char c, uint64_t* tokens) {
  bool in_token = false;
  for (;;) {
    if (pos_ >= end_ && !fill(pos_)) return false;
    const char* begin = buffer_.data() + pos_;
    const char* stop = static_cast<const char*>(std::memchr(begin, c, end_ - pos_));
    const char* limit = stop ? stop : buffer_.data() + end_;
    for (const char* p = begin; p < limit; ++p) {
      char ch = *p;
      bool space = ch == ' ' || ch == '\n' || ch == '\t' || ch == '\r';
      if (ch == '\n') ++line_;
      if (tokens && !space && !in_token) ++*tokens;
      in_token = !space;
    }
    pos_ = static_cast<size_t>(limit - buffer_.data());
    if (stop) return true;
  }
}

std::string_view Cursor::token() {
  skip_whitespace();
  size_t start = pos_;
  for (;;) {
    while (pos_ < end_) {
      char c = buffer_[pos_];
      if (c == ' ' || c == '\n' || c == '\t' || c == '\r' || c == '\f' || c == '\v' || (c == token_end_ && pos_ > start)) {
        return {buffer_.data() + start, pos_ - start};
      }
      ++pos_;
      if (pos_ - start > kMaxToken) fail("token longer than " + std::to_string(kMaxToken) + " characters");
    }
    size_t length = pos_ - start;
    if (!fill(start)) return {buffer_.data() + pos_ - length, length};
    start = pos_ - length;
  }
}

std::string_view Cursor::expect_token(std::string_view what) {
  std::string_view t = token();
  if (t.empty()) fail("unexpected end of file, expected " + std::string(what));
  return t;
}

bool Cursor::line_text(std::string_view& out) {
  size_t start = pos_;
  for (;;) {
    while (pos_ < end_) {
      if (buffer_[pos_] == '\n') {
        size_t len = pos_ - start;
        if (len > 0 && buffer_[start + len - 1] == '\r') --len;
        out = {buffer_.data() + start, len};
        ++pos_;
        ++line_;
        return true;
      }
      ++pos_;
      if (pos_ - start > kMaxToken * 16) fail("line longer than " + std::to_string(kMaxToken * 16) + " characters");
    }
    size_t length = pos_ - start;
    if (!fill(start)) {
      out = {buffer_.data() + pos_ - length, length};
      return length > 0;
    }
    start = pos_ - length;
  }
}

void Cursor::skip_to_next_line() {
  for (;;) {
    int c = peek();
    if (c == ' ' || c == '\t' || c == '\r') {
      ++pos_;
      continue;
    }
    if (c == '\n') {
      ++pos_;
      ++line_;
    }
    return;
  }
}

bool Cursor::next_line_starts_with(std::string_view word) {
  const uint64_t mark = offset(), mark_line = line_;
  skip_to_next_line();
  bool match = true;
  for (char c : word) {
    if (get() != static_cast<unsigned char>(c)) {
      match = false;
      break;
    }
  }
  seek(mark, mark_line);
  return match;
}

void Cursor::read(void* dst, size_t n, std::string_view what) {
  char* out = static_cast<char*>(dst);
  while (n > 0) {
    if (pos_ >= end_) {
      if (n >= buffer_.size()) {  // large reads go straight to the destination
        buffer_start_ += end_;
        pos_ = end_ = 0;
        size_t got = file_->read_at(buffer_start_, out, n);
        buffer_start_ += got;
        if (got < n) fail_byte("file truncated in " + std::string(what));
        return;
      }
      if (!fill(pos_)) fail_byte("file truncated in " + std::string(what));
    }
    size_t take = std::min(n, end_ - pos_);
    std::memcpy(out, buffer_.data() + pos_, take);
    pos_ += take;
    out += take;
    n -= take;
  }
}

void Cursor::skip(uint64_t n, std::string_view what) {
  if (n > remaining()) fail_byte("file truncated in " + std::string(what));
  uint64_t target = offset() + n;
  if (target <= buffer_start_ + end_) {
    pos_ = static_cast<size_t>(target - buffer_start_);
  } else {
    buffer_start_ = target;
    pos_ = end_ = 0;
  }
}

template <typename T>
T Cursor::parse_int(std::string_view what) {
  std::string_view t = expect_token(what);
  if constexpr (std::is_signed_v<T>) {
    int64_t v = 0;
    if (!parse_number(t, v) || v < std::numeric_limits<T>::min() || v > std::numeric_limits<T>::max()) {
      fail("expected " + std::string(what) + ", got " + quote_text(t));
    }
    return static_cast<T>(v);
  } else {
    uint64_t v = 0;
    if (!parse_number(t, v) || v > std::numeric_limits<T>::max()) {
      fail("expected " + std::string(what) + ", got " + quote_text(t));
    }
    return static_cast<T>(v);
  }
}
template int32_t Cursor::parse_int<int32_t>(std::string_view);
template int64_t Cursor::parse_int<int64_t>(std::string_view);
template uint32_t Cursor::parse_int<uint32_t>(std::string_view);
template uint64_t Cursor::parse_int<uint64_t>(std::string_view);

double Cursor::parse_double(std::string_view what) {
  std::string_view t = expect_token(what);
  double v = 0;
  if (!parse_number(t, v)) fail("expected " + std::string(what) + ", got " + quote_text(t));
  return v;
}

void Cursor::fail(std::string_view what) const {
  throw MeshError(file_->name() + ": line " + std::to_string(line_) + ": " + std::string(what));
}

void Cursor::fail_byte(std::string_view what) const { file_->fail_at_byte(offset(), what); }

std::string quote_text(std::string_view text) {
  std::string s;
  for (char c : text.substr(0, 40)) s += (c >= 32 && c < 127) ? c : '?';
  if (text.size() > 40) s += "...";
  return "'" + s + "'";
}

}  // namespace tetrascope::storage::detail
