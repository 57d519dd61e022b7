// Placeholder until the decimate stage lands.
#include "qjulia/decimate.h"

#include <stdexcept>
namespace qjulia {
TriMesh decimate(const TriMesh&, const DecimateOptions&, DecimateReport*) {
  throw std::runtime_error("decimate: not built yet");
}
}  // namespace qjulia
