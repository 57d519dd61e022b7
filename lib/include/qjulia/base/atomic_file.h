#pragma once
/// @file atomic_file.h
/// Write-to-temporary-then-rename, so a final file name never holds a half-written file. The
/// one writer of every output file of the library and the CLI.
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <utility>

#include "qjulia/base/progress.h"

namespace qjulia {

/// Checks that `path` may be written as an output file: it does not exist or is a regular file
/// (or a link to one), and its directory exists and is writable. An existing directory,
/// device, FIFO or socket is never replaced or renamed over.
/// @throws InvalidInput "PATH: why not" (exit code 2).
void check_output_path(const std::string& path);

/// A file written under a temporary name in the directory of `final_path` and renamed to
/// `final_path` by commit(). If commit() is never reached (an exception, a failed write,
/// cancellation), the destructor removes the temporary file. The data is flushed to the disk
/// (fsync) before the rename, so after a crash the final name holds either the old file or the
/// whole new one. A crash before commit() leaves at most a hidden temporary file
/// (".NAME.tmp-PID-N"), never a truncated file under the final name. A final path that is a
/// link to a regular file is replaced by the new file; the file it pointed to stays as it was.
class AtomicFile {
 public:
  /// Checks `final_path` (check_output_path) and creates the temporary file beside it, with a
  /// name no other writer uses (created exclusively). `cancel` is checked before every block
  /// written (at most 4 MiB each).
  /// @throws InvalidInput naming `final_path` when it may not be written (see
  ///         check_output_path; also a read-only file system); std::runtime_error when the
  ///         temporary file cannot be created for another reason.
  explicit AtomicFile(std::string final_path, const CancelToken* cancel = nullptr);
  ~AtomicFile();
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  /// Appends `size` bytes. @throws std::runtime_error naming the path on a write error (disk
  /// full, file too large, I/O error); Cancelled when the token is set.
  void write(const void* data, std::size_t size);
  void write(const std::string& s) { write(s.data(), s.size()); }

  /// The bytes of the file's stage, the buffer its writes go through.
  static constexpr std::size_t kStageBytes = std::size_t(1) << 22;
  /// Free room of at least `n` bytes (n <= kStageBytes) at the end of the stage, writing out
  /// what it holds first when it lacks the room: [first, last). Bytes put there join the file
  /// through staged(). Throws as write() does.
  std::pair<char*, char*> room(std::size_t n);
  /// Appends the first `n` bytes of the room room() returned last (n <= its size). Between
  /// room() and staged() the file takes no other write.
  void staged(std::size_t n) { staged_ += n; }

  /// The temporary file's path, for libraries that write a file themselves (lib3mf). Call
  /// close_for_external() before they write it.
  const std::string& temp_path() const { return temp_path_; }
  void close_for_external();

  /// Flushes to the disk, closes and renames onto the final path.
  /// @throws InvalidInput when the final path became a directory, device or FIFO meanwhile;
  ///         std::runtime_error when flushing or renaming fails; Cancelled when the token is
  ///         set. The temporary file is removed in every case.
  void commit();

  const std::string& final_path() const { return final_path_; }
  const CancelToken* cancel() const { return cancel_; }

 private:
  struct FreeStage {
    void operator()(char* p) const;
  };
  void check_open() const;
  void write_out(const char* p, std::size_t size);
  void buffered();           // the rest through the page cache (O_DIRECT off)
  void flush_stage();
  void spill(std::size_t n);  // writes out the stage's whole aligned blocks to make room for n
  void finish_pending();      // waits for the block being written out; throws its error
  std::string final_path_;
  std::string temp_path_;
  const CancelToken* cancel_ = nullptr;
  int fd_ = -1;
  bool committed_ = false;
  // Writes go through an aligned stage of kStageBytes; from the first full stage on, they
  // bypass the page cache (O_DIRECT) where the file system allows it.
  std::unique_ptr<char, FreeStage> stage_;
  std::size_t staged_ = 0;
  bool direct_ = false, direct_tried_ = false;
  // When the run may use two threads or more, a full stage is written out by a task of the
  // thread pool while the writer fills the spare one: at most one block in flight.
  struct Pending;
  std::unique_ptr<char, FreeStage> spare_;
  std::unique_ptr<Pending> pending_;
};

/// Formats output straight into an AtomicFile's stage (no buffer of its own, no copy): reserve
/// room, write there, advance past what was written. Bytes not flushed are not written.
class BufferedWriter {
 public:
  explicit BufferedWriter(AtomicFile& file) : file_(file) {}
  BufferedWriter(const BufferedWriter&) = delete;
  BufferedWriter& operator=(const BufferedWriter&) = delete;
  /// Reserves `n` bytes at the end and returns a pointer to them.
  char* reserve(std::size_t n) { return n <= std::size_t(end_ - cur_) ? cur_ : refill(n); }
  /// Commits `n` of the reserved bytes.
  void advance(std::size_t n) { cur_ += n; }
  /// The bytes reserve() can give without writing anything out (at least the last n asked).
  std::size_t room() const { return std::size_t(end_ - cur_); }
  void put(const char* s, std::size_t n);
  void put(const std::string& s) { put(s.data(), s.size()); }
  void put(char c) {
    *reserve(1) = c;
    ++cur_;
  }
  /// Hands the committed bytes to the file.
  void flush();

 private:
  char* refill(std::size_t n);
  AtomicFile& file_;
  char* begin_ = nullptr;  // the reserved span: the file's stage, or `large_`
  char* cur_ = nullptr;
  char* end_ = nullptr;
  std::string large_;  // a reservation larger than the stage
};

/// Bytes [offset, offset + size) of an AtomicFile, written by two threads of their own while the
/// file's owner goes on with other work and appends the bytes before `offset` (a multiple of
/// kAlignment). The threads take the blocks (AtomicFile::kStageBytes each) in turn, so one makes
/// its block while the other's goes out; each writes through a descriptor of its own, directly
/// to the disk where the file system allows it, and checks the file's cancel token before each
/// block. Waiting (finish()) must come before the file's commit(); the destructor stops the
/// threads and waits for them (the file is then given up with them).
class RegionWriter {
 public:
  static constexpr std::size_t kAlignment = 4096;
  /// fill(out, first, n) puts the region's bytes [first, first + n) at out.
  using Fill = std::function<void(char* out, std::uint64_t first, std::size_t n)>;
  /// Starts the threads. @throws std::logic_error when `offset` is not a multiple of kAlignment.
  RegionWriter(AtomicFile& file, std::uint64_t offset, std::uint64_t size, Fill fill);
  ~RegionWriter();
  RegionWriter(const RegionWriter&) = delete;
  RegionWriter& operator=(const RegionWriter&) = delete;
  /// Waits until the region is written. @throws std::runtime_error naming the path on a write
  /// error (as AtomicFile::write()), Cancelled when the token was set, or what `fill` threw.
  void finish();

 private:
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace qjulia
