// Placeholder until the export stage lands.
#include "qjulia/export.h"

#include <stdexcept>
namespace qjulia {
MeshFormat format_from_path(const std::string&) {
  throw std::runtime_error("export: not built yet");
}
void write_mesh(const std::string&, const TriMesh&, const ExportOptions&) {
  throw std::runtime_error("export: not built yet");
}
TriMesh read_mesh(const std::string&) { throw std::runtime_error("export: not built yet"); }
}  // namespace qjulia
