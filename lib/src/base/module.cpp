#include "qjulia/base/module.h"

#include <dlfcn.h>
#include <unistd.h>

#include <cstdlib>
#include <map>
#include <mutex>
#include <stdexcept>
#include <vector>

namespace qjulia {
namespace {

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

std::vector<std::string> candidates(const ModuleSpec& spec) {
  std::vector<std::string> c;
  if (const char* env = std::getenv(spec.env); env && *env) {
    c.push_back(env);
    return c;  // set: the only place looked at
  }
  const std::string dir = own_folder();
  if (!dir.empty()) {
    c.push_back(dir + "/" + spec.file);
    c.push_back(dir + "/../lib/qjulia/" + spec.file);
  }
  c.push_back(spec.build_path);
  c.push_back(spec.install_path);
  return c;
}

const void* open_module(const ModuleSpec& spec, std::string& error) {
  std::string tried;
  for (const std::string& path : candidates(spec)) {
    void* handle = ::dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (!handle) {
      const char* why = ::dlerror();
      tried += std::string(tried.empty() ? " " : "; ") + (why ? why : path + ": cannot be loaded");
      continue;
    }
    using Entry = const void* (*)();
    auto entry = reinterpret_cast<Entry>(::dlsym(handle, spec.entry));
    const void* api = entry ? entry() : nullptr;
    if (!api || *static_cast<const int*>(api) != spec.version) {
      tried += std::string(tried.empty() ? " " : "; ") + path +
               ": a module of another interface version";
      ::dlclose(handle);
      continue;
    }
    return api;  // stays loaded
  }
  error = std::string(spec.what) + " (" + spec.file + ") could not be loaded (set " + spec.env +
          " to its path):" + tried;
  return nullptr;
}

}  // namespace

const void* load_module(const ModuleSpec& spec) {
  struct Outcome {
    const void* api = nullptr;
    std::string error;
  };
  static std::mutex mutex;
  static std::map<std::string, Outcome> loaded;  // by file name
  const std::lock_guard<std::mutex> lock(mutex);
  auto [it, first] = loaded.try_emplace(spec.file);
  if (first) it->second.api = open_module(spec, it->second.error);
  if (!it->second.api) throw std::runtime_error(it->second.error);
  return it->second.api;
}

}  // namespace qjulia
