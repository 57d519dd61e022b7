#pragma once
/// @file comm.h
/// The processes of a distributed run, as the stages see them: a rank, a size, a few collective
/// operations on byte buffers, and one shared output file. The library holds no transport:
/// qjulia-mpi implements this with MPI (tests with threads). A run of one process has no Comm.
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

namespace qjulia {

class Comm {
 public:
  virtual ~Comm() = default;
  virtual int rank() const = 0;
  virtual int size() const = 0;
  /// Every rank sends to[r] to rank r and receives from[r] from each (all-to-all). Collective.
  virtual std::vector<std::string> exchange(const std::vector<std::string>& to) = 0;
  /// Every rank's `mine`, by rank. Collective.
  virtual std::vector<std::string> allgather(const std::string& mine) = 0;
  /// The sum over the ranks. Collective.
  virtual std::uint64_t sum(std::uint64_t mine) = 0;
  /// The ranks before this one, summed (0 on rank 0). Collective.
  virtual std::uint64_t exclusive_sum(std::uint64_t mine) = 0;
  /// True when any rank's `mine` is. Collective.
  virtual bool any(bool mine) = 0;
  /// Rank 0's `data` on every rank. Collective.
  virtual void broadcast(std::string& data) = 0;

  /// Opens (creates, truncates) `path` for writing by every rank; false on this rank's failure
  /// (the callers agree through any()). Collective.
  virtual bool file_open(const std::string& path) = 0;
  /// Writes `n` bytes at `offset` of the open file; false on failure. Not collective.
  virtual bool file_write_at(std::uint64_t offset, const char* data, std::size_t n) = 0;
  /// Closes the file (flushed to the system); false on this rank's failure. Collective.
  virtual bool file_close() = 0;

  /// Bytes this rank has sent to other ranks.
  std::uint64_t bytes_sent = 0;
  /// Seconds this rank has spent in collective operations (waiting for the others, mostly).
  double wait_seconds = 0;
};

/// Appends plain values to a byte buffer.
class Packer {
 public:
  template <class T>
  void put(const T& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    const char* p = reinterpret_cast<const char*>(&v);
    data.append(p, sizeof(T));
  }
  template <class T>
  void put_vector(const std::vector<T>& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    put<std::uint64_t>(v.size());
    if (!v.empty()) data.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
  }
  void put_bytes(const void* p, std::size_t n) {
    if (n > 0) data.append(static_cast<const char*>(p), n);
  }
  std::string data;
};

/// Reads what a Packer wrote, in the same order.
class Unpacker {
 public:
  explicit Unpacker(const std::string& data) : data_(data) {}
  template <class T>
  T get() {
    static_assert(std::is_trivially_copyable_v<T>);
    T v;
    take(&v, sizeof(T));
    return v;
  }
  template <class T>
  std::vector<T> get_vector() {
    const auto n = get<std::uint64_t>();
    if (n > (data_.size() - at_) / sizeof(T)) throw std::runtime_error("comm: truncated message");
    std::vector<T> v(n);
    take(v.data(), n * sizeof(T));
    return v;
  }
  void get_bytes(void* p, std::size_t n) { take(p, n); }
  bool done() const { return at_ == data_.size(); }

 private:
  void take(void* p, std::size_t n) {
    if (n > data_.size() - at_) throw std::runtime_error("comm: truncated message");
    if (n > 0) std::memcpy(p, data_.data() + at_, n);
    at_ += n;
  }
  const std::string& data_;
  std::size_t at_ = 0;
};

}  // namespace qjulia
