#include "qjulia/base/atomic_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <tbb/task_group.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <stdexcept>
#include <thread>
#include <tuple>
#include <utility>

#include "base/threads.h"
#include "qjulia/base/error.h"

namespace qjulia {
namespace {

constexpr std::size_t kBlock = AtomicFile::kStageBytes;  // bytes per write() between checks
constexpr std::size_t kAlign = 4096;  // what O_DIRECT needs of buffers, sizes and offsets
static_assert(kAlign == RegionWriter::kAlignment);

std::string errno_text(int err) { return std::strerror(err); }

// A block of kBlock bytes aligned for O_DIRECT, to free with std::free. @throws std::bad_alloc
char* aligned_block() {
  char* p = static_cast<char*>(std::aligned_alloc(kAlign, kBlock));
  if (!p) throw std::bad_alloc();
  return p;
}

// Turns O_DIRECT on or off for `fd`; false when fcntl fails.
bool set_direct(int fd, bool on) {
  const int flags = ::fcntl(fd, F_GETFL);
  return flags >= 0 && ::fcntl(fd, F_SETFL, on ? flags | O_DIRECT : flags & ~O_DIRECT) == 0;
}

// Writes [p, p + size) to `fd`: at *at (advanced) with pwrite(), or at the descriptor's position
// when `at` is null. While `direct` (O_DIRECT on), a direct write the file system refuses
// (EINVAL) or one that comes short calls buffered(), which turns O_DIRECT off and clears
// `direct`, and the rest goes through the page cache. Any other error calls fail(errno), which
// throws.
template <class Buffered, class Fail>
void write_all(int fd, const char* p, std::size_t size, std::uint64_t* at, const bool& direct,
               Buffered&& buffered, Fail&& fail) {
  while (size > 0) {
    const ssize_t n = at ? ::pwrite(fd, p, size, static_cast<off_t>(*at)) : ::write(fd, p, size);
    if (n < 0) {
      if (errno == EINTR) continue;
      if (errno == EINVAL && direct) {  // the file system refuses direct writes after all
        buffered();
        continue;
      }
      fail(errno);
    }
    p += n;
    size -= static_cast<std::size_t>(n);
    if (at) *at += static_cast<std::uint64_t>(n);
    if (direct && size > 0 && n % static_cast<ssize_t>(kAlign) != 0) buffered();  // short
  }
}

std::string directory_of(const std::string& path) {
  const auto slash = path.find_last_of('/');
  if (slash == std::string::npos) return ".";
  return slash == 0 ? "/" : path.substr(0, slash);
}

const char* kind_of(mode_t mode) {
  if (S_ISDIR(mode)) return "a directory";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  if (S_ISFIFO(mode)) return "a FIFO";
  if (S_ISSOCK(mode)) return "a socket";
  return "not a regular file";
}

/// Throws InvalidInput when `path` exists and is not a regular file (links followed).
void refuse_special_file(const std::string& path) {
  struct stat st;
  if (::stat(path.c_str(), &st) == 0 && !S_ISREG(st.st_mode)) {
    throw InvalidInput(path + ": exists and is " + kind_of(st.st_mode) +
                       "; an output never replaces one (choose another output path)");
  }
}

/// Errors of creating a file that are the caller's (a path that cannot be written: exit 2),
/// not the program's.
bool is_bad_path_error(int err) {
  return err == ENOENT || err == ENOTDIR || err == EACCES || err == EPERM || err == EROFS ||
         err == EISDIR || err == ENAMETOOLONG || err == ELOOP;
}

std::string temp_name_for(const std::string& final_path, unsigned attempt) {
  static std::atomic<unsigned> counter{0};
  const auto slash = final_path.find_last_of('/');
  const std::string dir = slash == std::string::npos ? "" : final_path.substr(0, slash + 1);
  std::string base = slash == std::string::npos ? final_path : final_path.substr(slash + 1);
  if (base.size() > 200) base.resize(200);  // the suffix must still fit NAME_MAX
  return dir + "." + base + ".tmp-" + std::to_string(::getpid()) + "-" +
         std::to_string(counter.fetch_add(1) + attempt);
}

}  // namespace

void check_output_path(const std::string& path) {
  if (path.empty()) throw InvalidInput("the output path is empty");
  refuse_special_file(path);
  struct stat st;
  if (::stat(path.c_str(), &st) != 0 && errno != ENOENT) {
    throw InvalidInput(path + ": cannot write the file (" + errno_text(errno) + ")");
  }
  const std::string dir = directory_of(path);
  if (::stat(dir.c_str(), &st) != 0 || !S_ISDIR(st.st_mode)) {
    throw InvalidInput(path + ": cannot write the file (the directory " + dir + " does not exist)");
  }
  if (::access(dir.c_str(), W_OK) != 0) {
    throw InvalidInput(path + ": cannot write in the directory " + dir + " (" + errno_text(errno) +
                       ")");
  }
}

AtomicFile::AtomicFile(std::string final_path, const CancelToken* cancel)
    : final_path_(std::move(final_path)), cancel_(cancel) {
  check_output_path(final_path_);
  for (unsigned attempt = 0; fd_ < 0; ++attempt) {
    temp_path_ = temp_name_for(final_path_, attempt);
    fd_ = ::open(temp_path_.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd_ >= 0) break;
    const int err = errno;
    if (err == EEXIST && attempt < 100) continue;  // another writer's name: take the next
    temp_path_.clear();
    const std::string msg = final_path_ + ": cannot create the file (" + errno_text(err) + ")";
    if (is_bad_path_error(err)) throw InvalidInput(msg);
    throw std::runtime_error(msg);
  }
}

// The block a task of the thread pool is writing out, if any.
struct AtomicFile::Pending {
  tbb::task_group group;
  bool running = false;
};

AtomicFile::~AtomicFile() {
  try {
    finish_pending();
  } catch (...) {  // the file is removed anyway
  }
  if (fd_ >= 0) ::close(fd_);
  if (!committed_ && !temp_path_.empty()) ::unlink(temp_path_.c_str());
}

void AtomicFile::check_open() const {
  if (fd_ < 0) throw std::logic_error("AtomicFile: write after close");
}

void AtomicFile::FreeStage::operator()(char* p) const { std::free(p); }

// Big files skip the page cache: copying 250 MB into it and flushing it with fsync() took about
// twice as long as writing it directly on the project machine. The data is staged in an aligned
// buffer of kBlock (writers format straight into it through room()); when it lacks room, its
// whole aligned blocks are written directly, by a task of the thread pool while the writer
// formats into a second stage (newton-cubic at 512: 60 writes of 136 ms in all, and 53 ms of
// formatting between them; a thread of its own per block gained less, competing with the pool's
// threads for two cores); the last, partial stage goes through the page cache. With one thread
// the stage is written out at once, as before. Waiting for the task may run other tasks of the
// pool on the writer's stack: the writers keep no thread-local state. File systems that refuse
// O_DIRECT (fcntl or the first write fails with EINVAL) are written through the page cache
// throughout.
void AtomicFile::write(const void* data, std::size_t size) {
  const char* p = static_cast<const char*>(data);
  while (size > 0) {
    const auto [first, last] = room(1);  // fills the stage to its end, as far as size goes
    const std::size_t n = std::min(size, std::size_t(last - first));
    std::memcpy(first, p, n);
    staged_ += n;
    p += n;
    size -= n;
  }
}

std::pair<char*, char*> AtomicFile::room(std::size_t n) {
  check_open();
  if (n > kBlock) throw std::logic_error("AtomicFile::room: more than the stage");
  if (!stage_) {
    stage_.reset(aligned_block());
  }
  if (kBlock - staged_ < n) spill(n);
  return {stage_.get() + staged_, stage_.get() + kBlock};
}

// Writes out the stage's whole aligned blocks (at once, or by a task while the writer goes on in
// the spare stage) and moves the rest (less than one block) to the start of the stage the writer
// goes on in; when that would leave less than `n` free, the rest goes out through the page cache
// at once.
void AtomicFile::spill(std::size_t n) {
  throw_if_cancelled(cancel_);
  finish_pending();
  if (!direct_tried_) {
    direct_tried_ = true;
    direct_ = set_direct(fd_, true);
  }
  const std::size_t head = direct_ ? staged_ / kAlign * kAlign : staged_;
  const std::size_t tail = staged_ - head;
  if (tail > 0 && kBlock - tail < n) {
    if (head > 0) write_out(stage_.get(), head);
    buffered();
    write_out(stage_.get() + head, tail);
    staged_ = 0;
    return;
  }
  if (head == 0) return;  // (the stage holds less than a block: nothing to write yet)
  if (detail::threads_that_may_run() < 2) {  // no thread to write while this one formats
    write_out(stage_.get(), head);
    if (tail > 0) std::memmove(stage_.get(), stage_.get() + head, tail);
    staged_ = tail;
    return;
  }
  // The head goes out from this stage while the writer goes on in the spare one, from the tail.
  if (!spare_) {
    spare_.reset(aligned_block());
  }
  if (tail > 0) std::memcpy(spare_.get(), stage_.get() + head, tail);
  if (!pending_) pending_ = std::make_unique<Pending>();
  const char* out = stage_.get();
  pending_->running = true;
  pending_->group.run([this, out, head] { write_out(out, head); });
  std::swap(stage_, spare_);
  staged_ = tail;
}

void AtomicFile::finish_pending() {
  if (!pending_ || !pending_->running) return;
  pending_->running = false;
  pending_->group.wait();  // rethrows the task's exception
}

// The last, partial stage: its whole aligned blocks directly, the rest through the page cache.
void AtomicFile::flush_stage() {
  finish_pending();
  if (staged_ == 0) return;
  const std::size_t head = direct_ ? staged_ / kAlign * kAlign : 0;
  if (head > 0) write_out(stage_.get(), head);
  if (staged_ > head) {
    buffered();
    write_out(stage_.get() + head, staged_ - head);
  }
  staged_ = 0;
}

void AtomicFile::buffered() {
  if (!direct_) return;
  direct_ = false;
  if (!set_direct(fd_, false))
    throw std::runtime_error(final_path_ + ": write failed (" + errno_text(errno) + ")");
}

void AtomicFile::write_out(const char* p, std::size_t size) {
  write_all(
      fd_, p, size, nullptr, direct_, [this] { buffered(); },
      [this](int err) {
        throw std::runtime_error(final_path_ + ": write failed (" + errno_text(err) + ")");
      });
}

void AtomicFile::close_for_external() {
  if (fd_ >= 0) {
    flush_stage();
    ::close(fd_);
    fd_ = -1;
  }
}

void AtomicFile::commit() {
  throw_if_cancelled(cancel_);
  if (fd_ >= 0) flush_stage();
  // fsync before the rename: the name must never point at data still in the page cache only.
  // It also reports a full disk on file systems that allocate late.
  int fd = fd_;
  fd_ = -1;
  if (fd < 0) fd = ::open(temp_path_.c_str(), O_RDONLY | O_CLOEXEC);  // written by a library
  if (fd < 0 || ::fsync(fd) != 0) {
    const int err = errno;
    if (fd >= 0) ::close(fd);
    throw std::runtime_error(final_path_ + ": write failed (" + errno_text(err) + ")");
  }
  if (::close(fd) != 0) {
    throw std::runtime_error(final_path_ + ": write failed (" + errno_text(errno) + ")");
  }
  refuse_special_file(final_path_);  // it may have appeared while the file was written
  if (::rename(temp_path_.c_str(), final_path_.c_str()) != 0) {
    const int err = errno;
    const std::string msg =
        final_path_ + ": cannot rename the temporary file onto it (" + errno_text(err) + ")";
    if (is_bad_path_error(err)) throw InvalidInput(msg);
    throw std::runtime_error(msg);
  }
  committed_ = true;
}

char* BufferedWriter::refill(std::size_t n) {
  flush();
  if (n <= AtomicFile::kStageBytes) {
    std::tie(begin_, end_) = file_.room(n);
  } else {
    large_.resize(n);
    begin_ = large_.data();
    end_ = begin_ + n;
  }
  cur_ = begin_;
  return cur_;
}

void BufferedWriter::put(const char* s, std::size_t n) {
  while (n > 0) {  // fills the room there is, so the stage goes out in whole blocks
    if (cur_ == end_) refill(1);
    const std::size_t k = std::min(n, std::size_t(end_ - cur_));
    std::memcpy(cur_, s, k);
    cur_ += k;
    s += k;
    n -= k;
  }
}

void BufferedWriter::flush() {
  const std::size_t n = std::size_t(cur_ - begin_);
  if (begin_ == large_.data() && !large_.empty()) {
    const std::string large = std::move(large_);
    large_.clear();
    begin_ = cur_ = end_ = nullptr;
    file_.write(large.data(), n);
    return;
  }
  if (n > 0) file_.staged(n);
  begin_ = cur_ = end_ = nullptr;
}

// ---------------------------------------------------------------------------- RegionWriter

// Two workers take the blocks in turn (block k by worker k % 2), each formatting its block while
// the other's is being written.
struct RegionWriter::State {
  static constexpr int kWorkers = 2;
  std::string temp_path, final_path;
  const CancelToken* cancel = nullptr;
  std::uint64_t offset = 0, size = 0;
  Fill fill;
  std::atomic<bool> stop{false};
  std::exception_ptr errors[kWorkers];  // set by the workers, read after they are joined
  std::thread workers[kWorkers];

  void join() {
    for (std::thread& t : workers)
      if (t.joinable()) t.join();
  }

  void run(int worker) noexcept {
    int fd = -1;
    char* buffer = nullptr;
    try {
      fd = ::open(temp_path.c_str(), O_WRONLY | O_CLOEXEC | O_DIRECT);
      bool direct = fd >= 0;
      if (fd < 0) fd = ::open(temp_path.c_str(), O_WRONLY | O_CLOEXEC);  // no O_DIRECT there
      if (fd < 0) fail(errno);
      buffer = aligned_block();
      auto buffered = [&] {
        if (!set_direct(fd, false)) fail(errno);
        direct = false;
      };
      for (std::uint64_t done = std::uint64_t{kBlock} * worker; done < size;
           done += std::uint64_t{kBlock} * kWorkers) {
        if (stop.load(std::memory_order_relaxed)) break;
        throw_if_cancelled(cancel);
        const std::size_t n =
            static_cast<std::size_t>(std::min<std::uint64_t>(kBlock, size - done));
        fill(buffer, done, n);
        if (direct && n % kAlign != 0) buffered();  // the region's last, partial block
        std::uint64_t at = offset + done;
        write_all(fd, buffer, n, &at, direct, buffered, [this](int err) { fail(err); });
      }
      const int closing = fd;
      fd = -1;
      if (::close(closing) != 0) fail(errno);
    } catch (...) {
      errors[worker] = std::current_exception();
      stop = true;  // the other worker stops too
    }
    if (fd >= 0) ::close(fd);
    std::free(buffer);
  }
  [[noreturn]] void fail(int err) const {
    throw std::runtime_error(final_path + ": write failed (" + errno_text(err) + ")");
  }
};

RegionWriter::RegionWriter(AtomicFile& file, std::uint64_t offset, std::uint64_t size, Fill fill)
    : state_(std::make_unique<State>()) {
  if (offset % kAlign != 0)
    throw std::logic_error("RegionWriter: the offset is not a multiple of the alignment");
  State& s = *state_;
  s.temp_path = file.temp_path();
  s.final_path = file.final_path();
  s.cancel = file.cancel();
  s.offset = offset;
  s.size = size;
  s.fill = std::move(fill);
  try {
    for (int w = 0; w < State::kWorkers; ++w) s.workers[w] = std::thread([&s, w] { s.run(w); });
  } catch (...) {  // a thread that could not start
    s.stop = true;
    s.join();
    throw;
  }
}

RegionWriter::~RegionWriter() {
  state_->stop = true;
  state_->join();
}

void RegionWriter::finish() {
  state_->join();
  for (std::exception_ptr& e : state_->errors)
    if (e) std::rethrow_exception(std::exchange(e, nullptr));
}

}  // namespace qjulia
