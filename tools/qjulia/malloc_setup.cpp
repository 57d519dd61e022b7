#include "malloc_setup.h"

#include <malloc.h>
#include <unistd.h>

#include <cctype>
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

/// Whether the user chose malloc's threshold `name` ("mmap" or "trim"): through GLIBC_TUNABLES
/// or glibc's older MALLOC_MMAP_THRESHOLD_ / MALLOC_TRIM_THRESHOLD_.
bool user_threshold(const std::string& name) {
  const char* t = std::getenv("GLIBC_TUNABLES");
  if (t && std::strstr(t, ("glibc.malloc." + name + "_threshold").c_str())) return true;
  std::string old = "MALLOC_" + name + "_THRESHOLD_";
  for (char& c : old) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return std::getenv(old.c_str()) != nullptr;
}

constexpr int kMmapThreshold = 32 << 20;  // glibc's largest (HEAP_MAX_SIZE / 2 on 64 bits)
constexpr int kTrimThreshold = 128 << 20;

}  // namespace

void fix_malloc_thresholds() {
  if (!user_threshold("mmap")) mallopt(M_MMAP_THRESHOLD, kMmapThreshold);
  if (!user_threshold("trim")) mallopt(M_TRIM_THRESHOLD, kTrimThreshold);
}

std::string malloc_thresholds_state() {
  const std::size_t before = mallinfo2().hblks;
  void* volatile block = std::malloc(std::size_t(16) << 20);
  const bool mapped = mallinfo2().hblks > before;
  std::free(block);
  std::string state =
      mapped ? "a 16 MiB block is mapped on its own" : "a 16 MiB block is on the heap";
  std::string user;
  for (const char* name : {"mmap", "trim"})
    if (user_threshold(name)) user += std::string(user.empty() ? "" : ", ") + name;
  if (!user.empty()) state += " (the user sets the " + user + " threshold)";
  return state;
}

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
