#pragma once
/// @file atomic_file.h
/// Write-to-temporary-then-rename, so a final file name never holds a half-written file.
#include <cstddef>
#include <string>

namespace qjulia {

/// A file written under a temporary name in the directory of `final_path` and renamed to
/// `final_path` by commit(). If commit() is never reached (an exception, a failed write), the
/// destructor removes the temporary file. A crash leaves at most a hidden temporary file, never
/// a truncated file under the final name.
class AtomicFile {
 public:
  /// Creates the temporary file (exclusive, next to `final_path`).
  /// @throws std::runtime_error naming `final_path` when it cannot be created (e.g. the
  ///         directory does not exist).
  explicit AtomicFile(std::string final_path);
  ~AtomicFile();
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  /// Appends `size` bytes. @throws std::runtime_error on a write error (disk full, ...).
  void write(const void* data, std::size_t size);
  void write(const std::string& s) { write(s.data(), s.size()); }

  /// The temporary file's path, for libraries that write a file themselves (lib3mf). Call
  /// close_for_external() before they write it.
  const std::string& temp_path() const { return temp_path_; }
  void close_for_external();

  /// Flushes, closes and renames onto the final path. @throws std::runtime_error on failure.
  void commit();

  const std::string& final_path() const { return final_path_; }

 private:
  void check_open() const;
  std::string final_path_;
  std::string temp_path_;
  int fd_ = -1;
  bool committed_ = false;
};

/// A growing byte buffer for text output that flushes to an AtomicFile in big blocks.
class BufferedWriter {
 public:
  explicit BufferedWriter(AtomicFile& file, std::size_t block = std::size_t(1) << 24);
  /// Reserves `n` bytes at the end and returns a pointer to them (flushes first if needed).
  char* reserve(std::size_t n);
  /// Commits `n` of the reserved bytes.
  void advance(std::size_t n) { used_ += n; }
  void put(const char* s, std::size_t n);
  void put(const std::string& s) { put(s.data(), s.size()); }
  void put(char c) {
    *reserve(1) = c;
    ++used_;
  }
  void flush();

 private:
  AtomicFile& file_;
  std::string buf_;
  std::size_t used_ = 0;
};

}  // namespace qjulia
