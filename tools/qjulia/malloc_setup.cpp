#include "malloc_setup.h"

#include <fcntl.h>
#include <malloc.h>
#include <sys/prctl.h>
#include <unistd.h>

#include <cctype>
#include <cstdlib>
#include <cstring>
#include <thread>
#include <utility>

#include "qjulia/base/memory.h"

namespace qjulia::cli {
namespace {

constexpr const char* kTunable = "glibc.malloc.hugetlb";

/// The kernel's transparent huge page mode: "always", "madvise", "never", or "" when unknown.
/// Plain libc: the restart reads it before the C++ runtime is initialised.
const char* thp_mode() {
  const int fd = open("/sys/kernel/mm/transparent_hugepage/enabled", O_RDONLY | O_CLOEXEC);
  if (fd < 0) return "";
  char line[128];
  const ssize_t n = read(fd, line, sizeof line - 1);
  close(fd);
  if (n <= 0) return "";
  line[n] = '\0';
  if (std::strstr(line, "[always]")) return "always";
  if (std::strstr(line, "[madvise]")) return "madvise";
  if (std::strstr(line, "[never]")) return "never";
  return "";
}

bool tunable_set() {
  const char* t = std::getenv("GLIBC_TUNABLES");
  return t && std::strstr(t, kTunable);
}

/// Whether the user chose malloc's setting `name` ("mmap_threshold", "trim_threshold",
/// "top_pad"): through GLIBC_TUNABLES or glibc's older MALLOC_MMAP_THRESHOLD_,
/// MALLOC_TRIM_THRESHOLD_ or MALLOC_TOP_PAD_.
bool user_setting(const std::string& name) {
  const char* t = std::getenv("GLIBC_TUNABLES");
  if (t && std::strstr(t, ("glibc.malloc." + name).c_str())) return true;
  std::string old = "MALLOC_" + name + "_";
  for (char& c : old) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return std::getenv(old.c_str()) != nullptr;
}

constexpr int kMmapThreshold = 32 << 20;  // glibc's largest (HEAP_MAX_SIZE / 2 on 64 bits)
constexpr int kTrimThreshold = 128 << 20;
constexpr int kTopPad = 64 << 20;  // a whole heap of a thread's arena (HEAP_MAX_SIZE)

}  // namespace

void fix_malloc_thresholds() {
  if (!user_setting("mmap_threshold")) mallopt(M_MMAP_THRESHOLD, kMmapThreshold);
  if (!user_setting("trim_threshold")) mallopt(M_TRIM_THRESHOLD, kTrimThreshold);
  if (!user_setting("top_pad")) mallopt(M_TOP_PAD, kTopPad);
}

std::string malloc_thresholds_state() {
  constexpr std::size_t kBlock = std::size_t(16) << 20;
  const struct mallinfo2 before = mallinfo2();
  void* volatile block = std::malloc(kBlock);
  const struct mallinfo2 after = mallinfo2();
  std::free(block);
  std::string state;
  if (after.hblkhd >= before.hblkhd + kBlock)
    state = "a 16 MiB block is mapped on its own";
  else if (after.uordblks >= before.uordblks + kBlock)
    state = "a 16 MiB block is on the heap";
  else
    return "malloc is not glibc's (a sanitizer's?): its thresholds do not apply";
  // A new thread's first small block makes its arena's heap: with the top pad, whole.
  std::size_t heap = 0;
  std::thread([&] {
    const std::size_t old = mallinfo2().arena;
    void* volatile small = std::malloc(64);
    heap = mallinfo2().arena - old;
    std::free(small);
  }).join();
  state += heap >= std::size_t(kTopPad / 2) ? ", a new thread's heap is whole at once"
                                            : ", a new thread's heap grows page by page";
  std::string user;
  for (const auto& [name, label] :
       {std::pair{"mmap_threshold", "mmap threshold"},
        std::pair{"trim_threshold", "trim threshold"}, std::pair{"top_pad", "top pad"}})
    if (user_setting(name)) user += std::string(user.empty() ? "" : ", ") + label;
  if (!user.empty()) state += " (the user sets the " + user + ")";
  return state;
}

std::string malloc_huge_pages_state() {
  const std::string mode = thp_mode();
  if (mode.empty()) return "off (the kernel offers no transparent huge pages)";
  if (mode == "never") return "off (the kernel's mode is never)";
  const HugePageChoice choice = huge_page_choice();
  if (mode == "always")
    return choice.on ? "on (the kernel's mode is always)"
                     : std::string("off (") + choice.why + "; the process opted out)";
  const char* t = std::getenv("GLIBC_TUNABLES");
  if (t && std::strstr(t, "glibc.malloc.hugetlb=1"))
    return "on (GLIBC_TUNABLES glibc.malloc.hugetlb=1)";
  if (tunable_set()) return "off (GLIBC_TUNABLES sets glibc.malloc.hugetlb otherwise)";
  if (!choice.on) return std::string("off (") + choice.why + ")";
  return "off";
}

void restart_with_malloc_huge_pages(char** argv) {
  // Plain libc only: this runs before the C++ runtime and the libraries are initialised.
  if (!huge_page_choice().on) {  // they do not pay here, or the user said no
    // Under the kernel's mode `always` the heap would get huge pages unasked.
    if (std::strcmp(thp_mode(), "always") == 0) prctl(PR_SET_THP_DISABLE, 1, 0, 0, 0);
    return;
  }
  if (tunable_set() || std::strcmp(thp_mode(), "madvise") != 0) return;
  const char* old = std::getenv("GLIBC_TUNABLES");
  char saved[4096];
  if (old && std::strlen(old) + std::strlen(kTunable) + 3 > sizeof saved) return;
  if (old) std::strcpy(saved, old);
  char value[4096];
  std::strcpy(value, old ? saved : "");
  if (old && *old) std::strcat(value, ":");
  std::strcat(value, kTunable);
  std::strcat(value, "=1");
  if (setenv("GLIBC_TUNABLES", value, 1) != 0 || !tunable_set()) return;  // never a loop
  execv("/proc/self/exe", argv);
  // The restart failed (no /proc, say): go on as we are, with the environment as it was.
  if (old) {
    setenv("GLIBC_TUNABLES", saved, 1);
  } else {
    unsetenv("GLIBC_TUNABLES");
  }
}

void restart_early(int argc, char** argv, char** envp) {
  if (argc < 2) return;
  // The C library sets `environ` in its own initialiser, which has not run yet: without this,
  // getenv would find nothing and setenv would start an environment of one variable.
  environ = envp;
  for (const char* command : {"mesh", "compare", "render", "experiment", "bench", "explore"})
    if (std::strcmp(argv[1], command) == 0) return restart_with_malloc_huge_pages(argv);
}

}  // namespace qjulia::cli
