// Finds and loads libqjulia_vdb.so on first use (see vdb_module.h).
#include "base/vdb_module.h"
#include "qjulia/base/module.h"

namespace qjulia::detail {

const VdbApi& vdb_api() {
  static const ModuleSpec spec{"libqjulia_vdb.so",      "QJULIA_VDB_MODULE", QJULIA_VDB_BUILD_PATH,
                               QJULIA_VDB_INSTALL_PATH, "qjulia_vdb_api",    kVdbApiVersion,
                               "OpenVDB support"};
  return module_api<VdbApi>(spec);
}

}  // namespace qjulia::detail
