// Placeholder until the render stage lands.
#include "qjulia/render.h"

#include <stdexcept>
namespace qjulia {
Image render(const TriMesh&, const RenderOptions&) {
  throw std::runtime_error("render: not built yet");
}
void write_png(const std::string&, const Image&) {
  throw std::runtime_error("render: not built yet");
}
}  // namespace qjulia
