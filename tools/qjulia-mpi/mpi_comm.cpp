#include "mpi_comm.h"

#include <algorithm>
#include <chrono>
#include <climits>

namespace qjulia::mpi {
namespace {

constexpr std::size_t kBlock = std::size_t{1} << 30;  // bytes per MPI call at most

// Adds the seconds of its scope to `total`.
class Timed {
 public:
  explicit Timed(double& total) : total_(total), start_(std::chrono::steady_clock::now()) {}
  ~Timed() {
    total_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  }

 private:
  double& total_;
  std::chrono::steady_clock::time_point start_;
};

}  // namespace

MpiComm::MpiComm(MPI_Comm comm) : comm_(comm) {
  MPI_Comm_rank(comm_, &rank_);
  MPI_Comm_size(comm_, &size_);
}

std::vector<std::string> MpiComm::exchange(const std::vector<std::string>& to) {
  Timed timed(wait_seconds);
  std::vector<std::uint64_t> out_sizes(size_), in_sizes(size_);
  for (int r = 0; r < size_; ++r) out_sizes[r] = to[r].size();
  MPI_Alltoall(out_sizes.data(), 1, MPI_UINT64_T, in_sizes.data(), 1, MPI_UINT64_T, comm_);
  std::vector<std::string> from(size_);
  from[rank_] = to[rank_];
  std::vector<MPI_Request> requests;
  for (int r = 0; r < size_; ++r) {
    if (r == rank_) continue;
    from[r].resize(in_sizes[r]);
    for (std::size_t at = 0; at < in_sizes[r]; at += kBlock) {
      requests.emplace_back();
      MPI_Irecv(from[r].data() + at, static_cast<int>(std::min(kBlock, in_sizes[r] - at)), MPI_BYTE,
                r, 0, comm_, &requests.back());
    }
  }
  for (int r = 0; r < size_; ++r) {
    if (r == rank_) continue;
    for (std::size_t at = 0; at < to[r].size(); at += kBlock) {
      requests.emplace_back();
      MPI_Isend(to[r].data() + at, static_cast<int>(std::min(kBlock, to[r].size() - at)), MPI_BYTE,
                r, 0, comm_, &requests.back());
    }
    bytes_sent += to[r].size();
  }
  MPI_Waitall(static_cast<int>(requests.size()), requests.data(), MPI_STATUSES_IGNORE);
  return from;
}

std::vector<std::string> MpiComm::allgather(const std::string& mine) {
  return exchange(std::vector<std::string>(size_, mine));
}

std::uint64_t MpiComm::sum(std::uint64_t mine) {
  Timed timed(wait_seconds);
  std::uint64_t total = 0;
  MPI_Allreduce(&mine, &total, 1, MPI_UINT64_T, MPI_SUM, comm_);
  return total;
}

std::uint64_t MpiComm::exclusive_sum(std::uint64_t mine) {
  Timed timed(wait_seconds);
  std::uint64_t before = 0;
  MPI_Exscan(&mine, &before, 1, MPI_UINT64_T, MPI_SUM, comm_);
  return rank_ == 0 ? 0 : before;  // MPI leaves rank 0's result undefined
}

bool MpiComm::any(bool mine) {
  Timed timed(wait_seconds);
  int in = mine ? 1 : 0, out = 0;
  MPI_Allreduce(&in, &out, 1, MPI_INT, MPI_LOR, comm_);
  return out != 0;
}

void MpiComm::broadcast(std::string& data) {
  Timed timed(wait_seconds);
  std::uint64_t n = data.size();
  MPI_Bcast(&n, 1, MPI_UINT64_T, 0, comm_);
  data.resize(n);
  for (std::size_t at = 0; at < n; at += kBlock)
    MPI_Bcast(data.data() + at, static_cast<int>(std::min(kBlock, n - at)), MPI_BYTE, 0, comm_);
  if (rank_ == 0) bytes_sent += n * (size_ - 1);
}

bool MpiComm::file_open(const std::string& path) {
  Timed timed(wait_seconds);
  const int rc =
      MPI_File_open(comm_, path.c_str(), MPI_MODE_WRONLY | MPI_MODE_CREATE, MPI_INFO_NULL, &file_);
  return rc == MPI_SUCCESS;
}

bool MpiComm::file_write_at(std::uint64_t offset, const char* data, std::size_t n) {
  for (std::size_t at = 0; at < n; at += kBlock) {
    const int count = static_cast<int>(std::min(kBlock, n - at));
    MPI_Status status;
    if (MPI_File_write_at(file_, static_cast<MPI_Offset>(offset + at), data + at, count, MPI_BYTE,
                          &status) != MPI_SUCCESS)
      return false;
    int written = 0;
    MPI_Get_count(&status, MPI_BYTE, &written);
    if (written != count) return false;
  }
  return true;
}

bool MpiComm::file_close() {
  Timed timed(wait_seconds);
  if (file_ == MPI_FILE_NULL) return false;
  return MPI_File_close(&file_) == MPI_SUCCESS;
}

}  // namespace qjulia::mpi
