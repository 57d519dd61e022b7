// Finds and loads libqjulia_openmesh.so on first use (see openmesh_module.h).
#include "mesh/openmesh_module.h"
#include "qjulia/base/module.h"

namespace qjulia::detail {

const OpenMeshApi& openmesh_api() {
  static const ModuleSpec spec{"libqjulia_openmesh.so",    "QJULIA_OPENMESH_MODULE",
                               QJULIA_OPENMESH_BUILD_PATH, QJULIA_OPENMESH_INSTALL_PATH,
                               "qjulia_openmesh_api",      kOpenMeshApiVersion,
                               "OpenMesh's decimation"};
  return module_api<OpenMeshApi>(spec);
}

}  // namespace qjulia::detail
