// Byte access to untrusted input files: random reads (pread or memory) and a buffered
// cursor with text tokens, line tracking and bounded binary reads. Every failure becomes
// a MeshError that names the file and the line (text) or byte offset (binary).
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "tetrascope/storage/mesh_error.h"
#include "tetrascope/storage/mesh_stream.h"

#include "tetrascope/storage/parse_number.h"

namespace tetrascope::storage::detail {

class InputFile {
 public:
  // Refuses anything but a regular file, without blocking: opened O_NONBLOCK (a FIFO with no
  // writer would otherwise block open()) and then checked with fstat.
  static std::shared_ptr<InputFile> open(const std::filesystem::path& path, const ReadLimits& limits = {});
  static std::shared_ptr<InputFile> from_memory(std::string name, std::span<const char> bytes, const ReadLimits& limits = {});
  ~InputFile();
  InputFile(const InputFile&) = delete;
  InputFile& operator=(const InputFile&) = delete;

  uint64_t size() const { return size_; }
  const std::string& name() const { return name_; }
  const ReadLimits& limits() const { return limits_; }
  // Reads up to n bytes at offset; returns how many were read (fewer only at the end).
  size_t read_at(uint64_t offset, void* dst, size_t n) const;

  [[noreturn]] void fail_at_byte(uint64_t offset, std::string_view what) const;

 private:
  InputFile() = default;
  std::string name_;
  int fd_ = -1;
  uint64_t size_ = 0;
  std::vector<char> memory_;
  ReadLimits limits_;
};

// A sequential cursor over an InputFile with its own buffer. Text mode counts lines
// and reports errors by line; binary reads report byte offsets.
class Cursor {
 public:
  static constexpr size_t kBufferBytes = 256 * 1024;
  static constexpr size_t kMaxToken = 4096;

  explicit Cursor(std::shared_ptr<const InputFile> file, uint64_t offset = 0, uint64_t line = 1);

  void seek(uint64_t offset, uint64_t line);
  uint64_t offset() const { return buffer_start_ + pos_; }
  uint64_t line() const { return line_; }
  uint64_t remaining() const { return file_->size() - offset(); }
  const InputFile& file() const { return *file_; }

  // Whitespace-separated token; empty view at end of file. Valid until the next call. A token
  // also ends before the character given to end_tokens_at (XML: '<', so "1.5</DataArray>" reads 1.5).
  std::string_view token();
  void end_tokens_at(char c) { token_end_ = c; }
  // Like token() but fails with `what` at end of file.
  std::string_view expect_token(std::string_view what);
  // Rest of the current line (without the newline), consuming the newline.
  // Returns false at end of file.
  bool line_text(std::string_view& out);
  // Skips spaces and tabs and then one line break, if any (used after binary headers).
  void skip_to_next_line();
  void skip_whitespace();
  // Whether the line after the current one starts with `word`; moves nothing. Safe before
  // binary data (reads only word.size() bytes, never a token).
  bool next_line_starts_with(std::string_view word);
  bool at_end();
  // Next byte without consuming it; -1 at end.
  int peek();
  // Next byte, consumed; -1 at end.
  int get();
  // Advances to the next `c` (not consumed); false at end of file. When `tokens` is given,
  // adds the number of whitespace-separated tokens passed over.
  bool skip_until(char c, uint64_t* tokens = nullptr);

  // Binary reads: exactly n bytes or a "truncated" error.
  void read(void* dst, size_t n, std::string_view what);
  void skip(uint64_t n, std::string_view what);

  template <typename T>
  T parse_int(std::string_view what);
  double parse_double(std::string_view what);

  [[noreturn]] void fail(std::string_view what) const;        // "file: line L: what"
  [[noreturn]] void fail_byte(std::string_view what) const;   // "file: byte B: what"

 private:
  bool fill(size_t keep_from);

  std::shared_ptr<const InputFile> file_;
  std::vector<char> buffer_;
  uint64_t buffer_start_ = 0;
  size_t pos_ = 0;
  size_t end_ = 0;
  char token_end_ = ' ';  // a character that ends a token besides white space
  uint64_t line_ = 1;
};

using tetrascope::parse_number;

std::string quote_text(std::string_view text);  // 'text', shortened to 40 characters

}  // namespace tetrascope::storage::detail
