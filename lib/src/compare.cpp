// Placeholder until the compare stage lands.
#include "qjulia/compare.h"

#include <stdexcept>
namespace qjulia {
CompareResult compare(const TriMesh&, const TriMesh&, const CompareOptions&) {
  throw std::runtime_error("compare: not built yet");
}
}  // namespace qjulia
