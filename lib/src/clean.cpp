// Placeholder until the clean stage lands.
#include "qjulia/clean.h"

#include <stdexcept>
namespace qjulia {
TriMesh clean(const TriMesh& m, const CleanOptions&, CleanReport*) { return m; }
std::size_t count_self_intersections(const TriMesh&) {
  throw std::runtime_error("clean: not built yet");
}
}  // namespace qjulia
