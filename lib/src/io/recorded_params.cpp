// read_params_from(): a parameter file, or the one a mesh file records. Apart from mesh_io.cpp,
// which the fuzzers build without the parameters' parser.
#include <optional>

#include "qjulia/base/error.h"
#include "qjulia/io/mesh_io.h"

namespace qjulia {

Params read_params_from(const std::string& path) {
  std::optional<MeshFormat> format;
  try {
    format = format_from_path(path);
  } catch (const InvalidInput&) {
    return read_params_file(path);  // not a mesh file's name: a parameter file
  }
  const std::string no_params = path + ": the mesh file records no parameters";
  // An STL never does, whatever it holds: it is not read (it may be large).
  if (*format == MeshFormat::kStl)
    throw InvalidInput(no_params + " (an STL file's are in its sidecar, " + path + ".json)");
  const std::string json = read_mesh_params(path);
  if (json.empty()) throw InvalidInput(no_params + " (it was not written by qjulia)");
  return parse_params(json, path);
}

}  // namespace qjulia
