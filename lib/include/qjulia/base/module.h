#pragma once
/// @file module.h
/// qjulia's modules: shared objects loaded on first use, so that the libraries behind them
/// (OpenVDB; cpp-httplib with OpenSSL) load only in the processes that need them.
#include <string>

namespace qjulia {

/// Where a module is and what it must answer.
struct ModuleSpec {
  const char* file = "";          ///< its file name, "libqjulia_vdb.so"
  const char* env = "";           ///< a variable that names its path (then the only place)
  const char* build_path = "";    ///< where the build puts it
  const char* install_path = "";  ///< where `cmake --install` puts it
  const char* entry = "";         ///< an extern "C" function that returns its interface
  int version = 0;                ///< the interface's first member (an int) must equal this
  const char* what = "";          ///< what it gives, for messages: "OpenVDB support"
};

/// Loads the module and returns what its entry returns; it stays loaded. Looked for, in this
/// order: the path in `env` when that is set (only there), beside the program or Python module
/// that links qjulia and in its ../lib/qjulia, `build_path`, `install_path`. The first call for
/// a module decides: later calls (from any thread) give its interface, or throw its error, again.
/// @throws std::runtime_error naming every path tried and why it failed, and `env`.
const void* load_module(const ModuleSpec& spec);

/// load_module() as the module's interface type.
template <class Api>
const Api& module_api(const ModuleSpec& spec) {
  return *static_cast<const Api*>(load_module(spec));
}

}  // namespace qjulia
