#include "base/distribution.h"

#include <stdexcept>

#include "qjulia/base/error.h"

namespace qjulia::detail {

void agree_on(Comm& comm, const std::exception_ptr& error) {
  std::string mine;
  if (error) {
    try {
      std::rethrow_exception(error);
    } catch (const TooLarge& e) {
      mine = std::string("T") + e.what();
    } catch (const InvalidInput& e) {
      mine = std::string("I") + e.what();
    } catch (const std::exception& e) {
      mine = std::string("R") + e.what();
    }
  }
  if (!comm.any(!mine.empty())) return;
  for (const std::string& e : comm.allgather(mine)) {
    if (e.empty()) continue;
    if (e[0] == 'T') throw TooLarge(e.substr(1));
    if (e[0] == 'I') throw InvalidInput(e.substr(1));
    throw std::runtime_error(e.substr(1));
  }
}

}  // namespace qjulia::detail
