// Placeholder until the print stage lands.
#include "qjulia/print.h"

#include <stdexcept>
namespace qjulia {
double scale_to_longest_side(TriMesh&, double) { throw std::runtime_error("print: not built yet"); }
TriMesh thicken(const TriMesh&, const ThickenOptions&) {
  throw std::runtime_error("print: not built yet");
}
}  // namespace qjulia
