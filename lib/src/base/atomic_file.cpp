#include "qjulia/base/atomic_file.h"

#include <fcntl.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <stdexcept>

#include "qjulia/base/error.h"

namespace qjulia {
namespace {

std::string errno_text() { return std::strerror(errno); }

std::string temp_name_for(const std::string& final_path) {
  static std::atomic<unsigned> counter{0};
  const auto slash = final_path.find_last_of('/');
  const std::string dir = slash == std::string::npos ? "" : final_path.substr(0, slash + 1);
  const std::string base = slash == std::string::npos ? final_path : final_path.substr(slash + 1);
  return dir + "." + base + ".tmp-" + std::to_string(::getpid()) + "-" +
         std::to_string(counter.fetch_add(1));
}

}  // namespace

AtomicFile::AtomicFile(std::string final_path) : final_path_(std::move(final_path)) {
  temp_path_ = temp_name_for(final_path_);
  fd_ = ::open(temp_path_.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
  if (fd_ < 0) {
    const std::string msg = final_path_ + ": cannot create the file (" + errno_text() + ")";
    // A path that cannot exist is bad input (exit code 2), not a failure of the program.
    if (errno == ENOENT || errno == ENOTDIR || errno == EACCES || errno == EISDIR ||
        errno == EROFS || errno == ENAMETOOLONG) {
      throw InvalidInput(msg);
    }
    throw std::runtime_error(msg);
  }
}

AtomicFile::~AtomicFile() {
  if (fd_ >= 0) ::close(fd_);
  if (!committed_) ::unlink(temp_path_.c_str());
}

void AtomicFile::check_open() const {
  if (fd_ < 0) throw std::logic_error("AtomicFile: write after close");
}

void AtomicFile::write(const void* data, std::size_t size) {
  check_open();
  const char* p = static_cast<const char*>(data);
  while (size > 0) {
    const ssize_t n = ::write(fd_, p, size);
    if (n < 0) {
      if (errno == EINTR) continue;
      throw std::runtime_error(final_path_ + ": write failed (" + errno_text() + ")");
    }
    p += n;
    size -= static_cast<std::size_t>(n);
  }
}

void AtomicFile::close_for_external() {
  if (fd_ >= 0) {
    ::close(fd_);
    fd_ = -1;
  }
}

void AtomicFile::commit() {
  if (fd_ >= 0) {
    const int fd = fd_;
    fd_ = -1;
    if (::close(fd) != 0) {
      throw std::runtime_error(final_path_ + ": write failed (" + errno_text() + ")");
    }
  }
  if (::rename(temp_path_.c_str(), final_path_.c_str()) != 0) {
    throw std::runtime_error(final_path_ + ": cannot rename the temporary file onto it (" +
                             errno_text() + ")");
  }
  committed_ = true;
}

BufferedWriter::BufferedWriter(AtomicFile& file, std::size_t block) : file_(file) {
  buf_.resize(block);
}

char* BufferedWriter::reserve(std::size_t n) {
  if (used_ + n > buf_.size()) {
    flush();
    if (n > buf_.size()) buf_.resize(n);
  }
  return buf_.data() + used_;
}

void BufferedWriter::put(const char* s, std::size_t n) {
  std::memcpy(reserve(n), s, n);
  used_ += n;
}

void BufferedWriter::flush() {
  if (used_ > 0) file_.write(buf_.data(), used_);
  used_ = 0;
}

}  // namespace qjulia
