#include "qjulia/base/memory.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>
#include <sstream>

#include "base/pages.h"
#include "base/threads.h"
#include "qjulia/base/error.h"

namespace qjulia {
namespace {

std::optional<std::size_t> read_number(const std::string& path) {
  std::ifstream in(path);
  std::string text;
  if (!(in >> text) || text == "max") return std::nullopt;
  try {
    const unsigned long long v = std::stoull(text);
    // cgroup v1 reports "no limit" as a huge page-aligned number.
    if (v >= (1ull << 60)) return std::nullopt;
    return static_cast<std::size_t>(v);
  } catch (...) {
    return std::nullopt;
  }
}

std::optional<std::size_t> meminfo(const char* key) {
  std::ifstream in("/proc/meminfo");
  std::string name;
  unsigned long long kib;
  std::string unit;
  while (in >> name >> kib) {
    std::getline(in, unit);
    if (name == key) return static_cast<std::size_t>(kib) * 1024;
  }
  return std::nullopt;
}

// The memory cgroup of this process: limit minus usage (v2 memory.max / memory.current, v1
// memory.limit_in_bytes / memory.usage_in_bytes).
std::optional<std::size_t> cgroup_room() {
  std::ifstream in("/proc/self/cgroup");
  std::string line;
  std::string v2_path, v1_path;
  bool v1 = false;
  while (std::getline(in, line)) {
    const auto a = line.find(':'), b = line.find(':', a + 1);
    if (a == std::string::npos || b == std::string::npos) continue;
    const std::string controllers = line.substr(a + 1, b - a - 1), path = line.substr(b + 1);
    if (controllers.empty()) v2_path = path;
    std::stringstream ss(controllers);
    for (std::string c; std::getline(ss, c, ',');)
      if (c == "memory") {
        v1 = true;
        v1_path = path;
      }
  }
  std::optional<std::size_t> limit, usage;
  if (v1) {
    for (const std::string& dir :
         {"/sys/fs/cgroup/memory" + v1_path, std::string("/sys/fs/cgroup/memory")}) {
      limit = read_number(dir + "/memory.limit_in_bytes");
      if (limit) {
        usage = read_number(dir + "/memory.usage_in_bytes");
        break;
      }
    }
  } else {
    const std::string dir = "/sys/fs/cgroup" + v2_path;
    limit = read_number(dir + "/memory.max");
    usage = read_number(dir + "/memory.current");
  }
  if (!limit) return std::nullopt;
  const std::size_t used = usage.value_or(0);
  return *limit > used ? *limit - used : 0;
}

std::optional<std::size_t> address_space_room() {
  rlimit r{};
  if (getrlimit(RLIMIT_AS, &r) != 0 || r.rlim_cur == RLIM_INFINITY) return std::nullopt;
  // The address space in use now: VmSize of /proc/self/status.
  std::size_t used = 0;
  std::ifstream in("/proc/self/status");
  std::string name;
  while (in >> name) {
    if (name == "VmSize:") {
      unsigned long long kib = 0;
      in >> kib;
      used = static_cast<std::size_t>(kib) * 1024;
      break;
    }
    std::string rest;
    std::getline(in, rest);
  }
  // What a run's threads reserve beyond the memory they hold: glibc's malloc gives each thread
  // that allocates a heap of 64 MiB (HEAP_MAX_SIZE) of address space, and the main heap's top is
  // padded by as much (the CLI's M_TOP_PAD). classic-julia at 512 reached 69 MiB more address
  // space than resident memory on one thread, 127 MiB on two; without this, on two threads it ran
  // out of address space at 66 MiB resident under a limit of 195 MiB, which the estimate
  // (105 MiB) had let it start under.
  used += detail::threads_that_may_run() * (std::size_t(64) << 20);
  const std::size_t limit = static_cast<std::size_t>(r.rlim_cur);
  return limit > used ? limit - used : 0;
}

}  // namespace

std::size_t MemoryLimits::effective() const {
  std::size_t m = std::numeric_limits<std::size_t>::max();
  for (const auto& v : {mem_available, cgroup, address_space, requested})
    if (v) m = std::min(m, *v);
  return m;
}

std::string MemoryLimits::describe() const {
  const std::size_t m = effective();
  if (m == std::numeric_limits<std::size_t>::max()) return "no limit";
  const char* which = requested && *requested == m           ? "--max-memory"
                      : address_space && *address_space == m ? "the address-space limit"
                      : cgroup && *cgroup == m               ? "the cgroup limit"
                                                             : "MemAvailable";
  return format_bytes(static_cast<double>(m)) + " (" + which + ")";
}

MemoryLimits memory_limits(std::optional<std::size_t> requested) {
  MemoryLimits l;
  l.mem_available = meminfo("MemAvailable:");
  l.cgroup = cgroup_room();
  l.address_space = address_space_room();
  l.requested = requested;
  return l;
}

std::size_t parse_memory_size(const std::string& text, const std::string& what) {
  auto bad = [&]() -> InvalidInput {
    return InvalidInput(what +
                        ": expected a size such as 4G, 512M or 1.5GiB (K, M, G, T = 2^10, "
                        "2^20, 2^30, 2^40 bytes; at least 1M), got '" +
                        text + "'");
  };
  std::size_t pos = 0;
  double value = 0;
  try {
    value = std::stod(text, &pos);
  } catch (...) {
    throw bad();
  }
  if (!std::isfinite(value) || value < 0 || text.empty() || !(text[0] >= '0' && text[0] <= '9'))
    throw bad();
  std::string unit = text.substr(pos);
  double scale = 1;
  if (!unit.empty()) {
    const char u = static_cast<char>(std::toupper(static_cast<unsigned char>(unit[0])));
    const std::string rest = unit.substr(1);
    const int power = u == 'K' ? 1 : u == 'M' ? 2 : u == 'G' ? 3 : u == 'T' ? 4 : u == 'B' ? 0 : -1;
    if (power < 0) throw bad();
    if (u == 'B' ? !rest.empty() : !(rest.empty() || rest == "B" || rest == "iB" || rest == "b"))
      throw bad();
    scale = std::ldexp(1.0, 10 * power);
  }
  const double bytes = value * scale;
  if (bytes < 1048576.0 || bytes > 9.0e18) throw bad();
  return static_cast<std::size_t>(bytes);
}

std::string format_bytes(double bytes) {
  static const char* const units[] = {"B", "KiB", "MiB", "GiB", "TiB", "PiB"};
  int u = 0;
  while (bytes >= 1024 && u < 5) {
    bytes /= 1024;
    ++u;
  }
  char buf[32];
  std::snprintf(buf, sizeof buf,
                u == 0       ? "%.0f %s"
                : bytes < 10 ? "%.2f %s"
                             : "%.1f %s",
                bytes, units[u]);
  return buf;
}

std::size_t peak_rss_bytes() {
  rusage usage{};
  if (getrusage(RUSAGE_SELF, &usage) != 0) return 0;
  return static_cast<std::size_t>(usage.ru_maxrss) * 1024;  // Linux reports KiB
}

std::size_t current_rss_bytes() {
  std::ifstream in("/proc/self/statm");
  unsigned long long pages_total = 0, pages_resident = 0;
  if (!(in >> pages_total >> pages_resident)) return 0;
  return static_cast<std::size_t>(pages_resident) * static_cast<std::size_t>(sysconf(_SC_PAGESIZE));
}

namespace {

// The order of the free blocks this machine reports to its host, or -1 when it cannot say (no
// such parameter, or a value out of range). Until a driver registers, recent kernels show an
// unsigned -1 there and older ones their largest order, both above 9.
int page_reporting_order() noexcept {
  const int fd =
      open("/sys/module/page_reporting/parameters/page_reporting_order", O_RDONLY | O_CLOEXEC);
  if (fd < 0) return -1;
  char text[32];
  const ssize_t n = read(fd, text, sizeof text - 1);
  close(fd);
  if (n <= 0) return -1;
  text[n] = '\0';
  char* end = nullptr;
  const long order = std::strtol(text, &end, 10);
  return end != text && order >= 0 && order < 64 ? static_cast<int>(order) : -1;
}

// The choices there are, and which applies: QJULIA_HUGE_PAGES's, or the machine's.
constexpr HugePageChoice kChoices[] = {
    {true, ""},
    {false, "QJULIA_HUGE_PAGES=0"},
    {true, "QJULIA_HUGE_PAGES=1"},
    {false, "the machine hands free 2 MiB blocks back to its host, page_reporting_order <= 9"}};

// Which of kChoices applies (its index).
int decide_huge_pages() noexcept {
  if (const char* v = std::getenv("QJULIA_HUGE_PAGES")) {
    if (std::strcmp(v, "0") == 0) return 1;
    if (std::strcmp(v, "1") == 0) return 2;
  }
  // A huge page is an order-9 block (2 MiB of 4 KiB pages).
  const int order = page_reporting_order();
  return order >= 0 && order <= 9 ? 3 : 0;
}

}  // namespace

HugePageChoice huge_page_choice() noexcept {
  // The index of the choice + 1; 0 while undecided (two threads deciding at once agree).
  static std::atomic<int> decided{0};
  int i = decided.load(std::memory_order_relaxed);
  if (i == 0) {
    i = decide_huge_pages() + 1;
    decided.store(i, std::memory_order_relaxed);
  }
  return kChoices[i - 1];
}

namespace detail {

void advise_huge_pages(void* p, std::size_t bytes) noexcept {
  madvise(p, bytes, huge_page_choice().on ? MADV_HUGEPAGE : MADV_NOHUGEPAGE);
}

bool populate_pages(void* p, std::size_t bytes) noexcept {
#ifndef MADV_POPULATE_WRITE
  constexpr int MADV_POPULATE_WRITE = 23;  // Linux 5.14; older headers lack the name
#endif
  if (bytes == 0) return true;
  // The whole pages that hold the range: a page partly in use keeps its contents.
  const auto page = static_cast<std::uintptr_t>(sysconf(_SC_PAGESIZE));
  const auto first = reinterpret_cast<std::uintptr_t>(p) & ~(page - 1);
  const auto end = reinterpret_cast<std::uintptr_t>(p) + bytes;
  return madvise(reinterpret_cast<void*>(first), end - first, MADV_POPULATE_WRITE) == 0;
}

}  // namespace detail

}  // namespace qjulia
