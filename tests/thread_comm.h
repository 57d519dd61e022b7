#pragma once
// Ranks as threads of one process, for testing the distributed stages without MPI: run(K, f)
// calls f(comm) on K threads, each with its own Comm; the collectives meet at a barrier.
#include <fcntl.h>
#include <unistd.h>

#include <condition_variable>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

#include "qjulia/base/comm.h"

namespace qjulia::test {

class ThreadWorld {
 public:
  explicit ThreadWorld(int size) : slots_(size), inbox_(size), size_(size) {}

  // Every rank posts its part, waits for all, reads, and waits again before the next round.
  template <class Post, class Read>
  void round(int rank, Post&& post, Read&& read) {
    std::unique_lock<std::mutex> lock(mutex_);
    post(rank);
    arrive(lock);
    read(rank);
    arrive(lock);
  }

  int size() const { return size_; }
  std::vector<std::string> slots_;               // allgather / broadcast / sums
  std::vector<std::vector<std::string>> inbox_;  // exchange: inbox_[to][from]
  int fd_ = -1;                                  // the shared output file

 private:
  void arrive(std::unique_lock<std::mutex>& lock) {
    const std::uint64_t gen = generation_;
    if (++count_ == size_) {
      count_ = 0;
      ++generation_;
      cv_.notify_all();
    } else {
      cv_.wait(lock, [&] { return generation_ != gen; });
    }
  }
  int size_;
  std::mutex mutex_;
  std::condition_variable cv_;
  int count_ = 0;
  std::uint64_t generation_ = 0;
};

class ThreadComm : public Comm {
 public:
  ThreadComm(ThreadWorld& world, int rank) : world_(world), rank_(rank) {}
  int rank() const override { return rank_; }
  int size() const override { return world_.size(); }
  std::vector<std::string> exchange(const std::vector<std::string>& to) override {
    std::vector<std::string> from;
    world_.round(
        rank_,
        [&](int r) {
          for (int t = 0; t < size(); ++t) {
            if (world_.inbox_[t].size() != static_cast<std::size_t>(size()))
              world_.inbox_[t].resize(size());
            world_.inbox_[t][r] = to[t];
            if (t != r) bytes_sent += to[t].size();
          }
        },
        [&](int r) { from = world_.inbox_[r]; });
    return from;
  }
  std::vector<std::string> allgather(const std::string& mine) override {
    std::vector<std::string> all;
    world_.round(
        rank_, [&](int r) { world_.slots_[r] = mine; }, [&](int) { all = world_.slots_; });
    return all;
  }
  std::uint64_t sum(std::uint64_t mine) override {
    std::uint64_t total = 0;
    for (const std::string& s : allgather(std::string(reinterpret_cast<char*>(&mine), 8))) {
      std::uint64_t v;
      std::memcpy(&v, s.data(), 8);
      total += v;
    }
    return total;
  }
  std::uint64_t exclusive_sum(std::uint64_t mine) override {
    std::uint64_t total = 0;
    const auto all = allgather(std::string(reinterpret_cast<char*>(&mine), 8));
    for (int r = 0; r < rank_; ++r) {
      std::uint64_t v;
      std::memcpy(&v, all[r].data(), 8);
      total += v;
    }
    return total;
  }
  bool any(bool mine) override { return sum(mine ? 1 : 0) > 0; }
  void broadcast(std::string& data) override { data = allgather(data)[0]; }
  bool file_open(const std::string& path) override {
    bool ok = true;
    world_.round(
        rank_,
        [&](int r) {
          if (r == 0) world_.fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
        },
        [&](int) { ok = world_.fd_ >= 0; });
    return ok;
  }
  bool file_write_at(std::uint64_t offset, const char* data, std::size_t n) override {
    while (n > 0) {
      const ssize_t w = ::pwrite(world_.fd_, data, n, static_cast<off_t>(offset));
      if (w <= 0) return false;
      data += w;
      n -= static_cast<std::size_t>(w);
      offset += static_cast<std::uint64_t>(w);
    }
    return true;
  }
  bool file_close() override {
    bool ok = true;
    world_.round(
        rank_, [](int) {},
        [&](int r) {
          if (r == 0) ok = ::close(world_.fd_) == 0;
        });
    return ok;
  }

 private:
  ThreadWorld& world_;
  int rank_;
};

/// Runs f(comm) on `ranks` threads; rethrows the first exception.
inline void run_ranks(int ranks, const std::function<void(Comm&)>& f) {
  ThreadWorld world(ranks);
  std::vector<std::thread> threads;
  std::vector<std::exception_ptr> errors(ranks);
  for (int r = 0; r < ranks; ++r)
    threads.emplace_back([&, r] {
      ThreadComm comm(world, r);
      try {
        f(comm);
      } catch (...) {
        errors[r] = std::current_exception();
      }
    });
  for (auto& t : threads) t.join();
  for (auto& e : errors)
    if (e) std::rethrow_exception(e);
}

}  // namespace qjulia::test
