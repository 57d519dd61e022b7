#include "huge_pages.h"

#include <unistd.h>

#include <cstdlib>
#include <cstring>
#include <fstream>

namespace qjulia::cli {
namespace {

constexpr const char* kTunable = "glibc.malloc.hugetlb";

/// The kernel's transparent huge page mode: "always", "madvise", "never", or "" when unknown.
std::string thp_mode() {
  std::ifstream in("/sys/kernel/mm/transparent_hugepage/enabled");
  std::string line;
  if (!std::getline(in, line)) return "";
  const auto open = line.find('['), close = line.find(']');
  if (open == std::string::npos || close == std::string::npos || close < open) return "";
  return line.substr(open + 1, close - open - 1);
}

bool opted_out() {
  const char* v = std::getenv("QJULIA_HUGE_PAGES");
  return v && std::strcmp(v, "0") == 0;
}

bool tunable_set() {
  const char* t = std::getenv("GLIBC_TUNABLES");
  return t && std::strstr(t, kTunable);
}

}  // namespace

std::string malloc_huge_pages_state() {
  const std::string mode = thp_mode();
  if (mode == "always") return "on (the kernel's mode is always)";
  if (mode.empty()) return "off (the kernel offers no transparent huge pages)";
  if (mode == "never") return "off (the kernel's mode is never)";
  const char* t = std::getenv("GLIBC_TUNABLES");
  if (t && std::strstr(t, "glibc.malloc.hugetlb=1"))
    return "on (GLIBC_TUNABLES glibc.malloc.hugetlb=1)";
  if (tunable_set()) return "off (GLIBC_TUNABLES sets glibc.malloc.hugetlb otherwise)";
  if (opted_out()) return "off (QJULIA_HUGE_PAGES=0)";
  return "off";
}

void restart_with_malloc_huge_pages(char** argv) {
  if (opted_out() || tunable_set() || thp_mode() != "madvise") return;
  const char* old = std::getenv("GLIBC_TUNABLES");
  const std::string saved = old ? old : "";
  const std::string value =
      saved.empty() ? std::string(kTunable) + "=1" : saved + ":" + kTunable + "=1";
  if (setenv("GLIBC_TUNABLES", value.c_str(), 1) != 0) return;
  execv("/proc/self/exe", argv);
  // The restart failed (no /proc, say): go on as we are, with the environment as it was.
  if (old) {
    setenv("GLIBC_TUNABLES", saved.c_str(), 1);
  } else {
    unsetenv("GLIBC_TUNABLES");
  }
}

}  // namespace qjulia::cli
