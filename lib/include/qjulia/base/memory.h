#pragma once
/// @file memory.h
/// How much memory a job may use, and what it has used: the one place that reads the limits.
#include <cstddef>
#include <optional>
#include <string>

namespace qjulia {

/// The limits that bound a job's memory, bytes; each unset when the system sets none.
struct MemoryLimits {
  std::optional<std::size_t> mem_available;  ///< MemAvailable of /proc/meminfo
  std::optional<std::size_t> cgroup;         ///< the cgroup's limit minus its current usage
  /// RLIMIT_AS minus the current address space and what malloc reserves beyond the memory it
  /// holds (64 MiB a thread)
  std::optional<std::size_t> address_space;
  std::optional<std::size_t> requested;  ///< what the caller allows (e.g. --max-memory)

  /// The smallest of the limits that are set; SIZE_MAX when none is.
  std::size_t effective() const;
  /// "4.0 GiB (MemAvailable)": the effective limit and which one it is.
  std::string describe() const;
};

/// Reads the system's limits now and adds `requested`.
MemoryLimits memory_limits(std::optional<std::size_t> requested = std::nullopt);

/// Parses a size: a non-negative number with an optional binary unit K, M, G, T (2^10, 2^20,
/// 2^30, 2^40 bytes; "B" and "iB" may follow: 4G, 512M, 1.5GiB, 1000000).
/// @throws InvalidInput naming `what` when the text is not such a size or is below 1 MiB.
std::size_t parse_memory_size(const std::string& text, const std::string& what);

/// A size for messages: "1.62 GiB", "512 MiB", "900 KiB", "12 B".
std::string format_bytes(double bytes);

/// Peak resident set size of this process so far, bytes (0 when unknown).
std::size_t peak_rss_bytes();

/// Resident set size of this process now, bytes (0 when unknown).
std::size_t current_rss_bytes();

/// Whether this process asks the kernel for transparent huge pages (2 MiB) for its large
/// memory (malloc's heap in the commands, the brick pool's slabs, the mesh's large arrays), and
/// why. `QJULIA_HUGE_PAGES=0` or `=1` decides when set. Otherwise yes, unless the machine hands
/// free blocks of 2 MiB back to its host (free page reporting at order 9 or below,
/// `/sys/module/page_reporting/parameters/page_reporting_order`): then every huge page comes
/// from a block the host has taken back and must back again, which costs several times what
/// 4 KiB pages from the smaller free blocks cost (on the project machine 3.2 against 0.42 ms a
/// MB). Decided once a process; plain C library calls only, so that a command can ask before the
/// C++ runtime is initialised.
struct HugePageChoice {
  bool on = true;
  const char* why = "";  ///< static text: the setting or the machine's reason; "" by default
};
HugePageChoice huge_page_choice() noexcept;

}  // namespace qjulia
