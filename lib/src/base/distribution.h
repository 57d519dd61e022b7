#pragma once
// How the bricks of a distributed run are dealt to its ranks.
#include <exception>
#include <vector>

#include "qjulia/base/comm.h"

namespace qjulia::detail {

/// How the bricks are dealt to the ranks: rank r owns the bricks whose x coordinate is in
/// [first[r], first[r + 1]) (contiguous slabs in the bricks' key order, so the mesh of the
/// ranks in rank order is the mesh of one process), chosen by the sampler from the estimated
/// cost of each plane of bricks.
struct Distribution {
  Comm* comm = nullptr;
  std::vector<int> first;  ///< size() + 1 entries once set
  int rank_of(int bx) const {
    int r = 0;
    while (r + 1 < static_cast<int>(first.size()) - 1 && bx >= first[r + 1]) ++r;
    return r;
  }
  bool owns(int bx) const {
    const int r = comm->rank();
    return bx >= first[r] && bx < first[r + 1];
  }
};

/// Every rank throws the first failing rank's error (TooLarge, InvalidInput, or else a
/// std::runtime_error with its message), or none does. Collective.
void agree_on(Comm& comm, const std::exception_ptr& error);

/// Runs f() on rank 0 only; then every rank throws what it threw, or none does. Collective.
template <class F>
void on_rank_zero(Comm& comm, F&& f) {
  std::exception_ptr error;
  if (comm.rank() == 0) {
    try {
      f();
    } catch (...) {
      error = std::current_exception();
    }
  }
  agree_on(comm, error);
}

}  // namespace qjulia::detail
