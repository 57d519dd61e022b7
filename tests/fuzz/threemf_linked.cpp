// The fuzz targets link the 3MF module's code (instrumented like the readers) instead of
// loading libqjulia_3mf.so.
#include "io/threemf_module.h"

namespace qjulia::detail {

const ThreeMfApi& threemf_api() { return *qjulia_3mf_api(); }

}  // namespace qjulia::detail
