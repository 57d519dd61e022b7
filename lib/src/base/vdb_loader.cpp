// Finds and loads libqjulia_vdb.so on first use (see vdb_module.h).
#include <mutex>
#include <stdexcept>
#include <string>

#include "base/vdb_module.h"
#include "qjulia/base/module.h"

namespace qjulia::detail {
namespace {

const VdbApi* load(std::string& error) {
  ModuleSpec spec;
  spec.file = "libqjulia_vdb.so";
  spec.env = "QJULIA_VDB_MODULE";
  spec.build_path = QJULIA_VDB_BUILD_PATH;
  spec.install_path = QJULIA_VDB_INSTALL_PATH;
  spec.entry = "qjulia_vdb_api";
  spec.version = kVdbApiVersion;
  spec.what = "OpenVDB support";
  try {
    return static_cast<const VdbApi*>(load_module(spec));
  } catch (const std::runtime_error& e) {
    error = e.what();
    return nullptr;
  }
}

}  // namespace

const VdbApi& vdb_api() {
  static std::once_flag once;
  static const VdbApi* api = nullptr;
  static std::string error;
  std::call_once(once, [] { api = load(error); });
  if (!api) throw std::runtime_error(error);
  return *api;
}

}  // namespace qjulia::detail
