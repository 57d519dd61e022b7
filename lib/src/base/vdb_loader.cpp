// Finds and loads libqjulia_vdb.so on first use (see vdb_module.h).
#include <dlfcn.h>
#include <unistd.h>

#include <cstdlib>
#include <mutex>
#include <stdexcept>
#include <string>
#include <vector>

#include "base/vdb_module.h"

namespace qjulia::detail {
namespace {

constexpr const char* kModule = "libqjulia_vdb.so";

// The folder of the program or shared module this code was linked into.
std::string own_folder() {
  Dl_info info{};
  if (::dladdr(reinterpret_cast<void*>(&own_folder), &info) == 0 || !info.dli_fname) return {};
  std::string path = info.dli_fname;
  if (path.find('/') == std::string::npos) {  // the main program, named without its folder
    char exe[4096];
    const ssize_t n = ::readlink("/proc/self/exe", exe, sizeof exe - 1);
    if (n <= 0) return {};
    path.assign(exe, static_cast<std::size_t>(n));
  }
  return path.substr(0, path.rfind('/'));
}

std::vector<std::string> candidates() {
  std::vector<std::string> c;
  if (const char* env = std::getenv("QJULIA_VDB_MODULE"); env && *env) {
    c.push_back(env);
    return c;  // set: the only place looked at
  }
  const std::string dir = own_folder();
  if (!dir.empty()) {
    c.push_back(dir + "/" + kModule);
    c.push_back(dir + "/../lib/qjulia/" + kModule);
  }
  c.push_back(QJULIA_VDB_BUILD_PATH);
  c.push_back(QJULIA_VDB_INSTALL_PATH);
  return c;
}

const VdbApi* load(std::string& error) {
  std::string tried;
  for (const std::string& path : candidates()) {
    void* handle = ::dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (!handle) {
      const char* why = ::dlerror();
      tried += std::string(tried.empty() ? " " : "; ") + (why ? why : path + ": cannot be loaded");
      continue;
    }
    using Entry = const VdbApi* (*)();
    auto entry = reinterpret_cast<Entry>(::dlsym(handle, "qjulia_vdb_api"));
    const VdbApi* api = entry ? entry() : nullptr;
    if (!api || api->version != kVdbApiVersion) {
      tried += std::string(tried.empty() ? " " : "; ") + path +
               ": a module of another interface version";
      ::dlclose(handle);
      continue;
    }
    return api;  // stays loaded
  }
  error = std::string("OpenVDB support (") + kModule +
          ") could not be loaded (set QJULIA_VDB_MODULE to its path):" + tried;
  return nullptr;
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
