#pragma once
// The library's Comm on MPI: every collective of a distributed run goes through MPI (point to
// point messages in blocks of at most 1 GiB, so no count overflows an int), and the shared
// output file is written with MPI-IO.
#include <mpi.h>

#include "qjulia/base/comm.h"

namespace qjulia::mpi {

class MpiComm : public Comm {
 public:
  explicit MpiComm(MPI_Comm comm);
  int rank() const override { return rank_; }
  int size() const override { return size_; }
  std::vector<std::string> exchange(const std::vector<std::string>& to) override;
  std::vector<std::string> allgather(const std::string& mine) override;
  std::uint64_t sum(std::uint64_t mine) override;
  std::uint64_t exclusive_sum(std::uint64_t mine) override;
  bool any(bool mine) override;
  void broadcast(std::string& data) override;
  bool file_open(const std::string& path) override;
  bool file_write_at(std::uint64_t offset, const char* data, std::size_t n) override;
  bool file_close() override;

 private:
  MPI_Comm comm_;
  int rank_ = 0, size_ = 1;
  MPI_File file_ = MPI_FILE_NULL;
};

}  // namespace qjulia::mpi
