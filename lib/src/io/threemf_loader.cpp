// Finds and loads libqjulia_3mf.so on first use (see threemf_module.h).
#include "io/threemf_module.h"
#include "qjulia/base/module.h"

namespace qjulia::detail {

const ThreeMfApi& threemf_api() {
  static const ModuleSpec spec{
      "libqjulia_3mf.so", "QJULIA_3MF_MODULE", QJULIA_3MF_BUILD_PATH, QJULIA_3MF_INSTALL_PATH,
      "qjulia_3mf_api",   kThreeMfApiVersion,  "3MF support"};
  return module_api<ThreeMfApi>(spec);
}

}  // namespace qjulia::detail
