// Transparent huge pages for malloc: the qjulia command restarts itself once with glibc's
// `glibc.malloc.hugetlb=1` tunable, which glibc reads only at a process's start.
#pragma once

#include <string>

namespace qjulia::cli {

/// Where the machine's transparent huge pages stand for this process: "on" (malloc asks for them),
/// or "off (...)" with the reason.
std::string malloc_huge_pages_state();

/// When the kernel gives transparent huge pages only to memory that asks for them (mode
/// `madvise`), and neither GLIBC_TUNABLES nor QJULIA_HUGE_PAGES=0 has decided otherwise, runs
/// this program again (same pid, arguments and environment, plus the tunable) so that malloc asks
/// for them: on a virtual machine a page fault costs several microseconds, and a run touches
/// every page of its memory once. Returns (and the run goes on as it is) when it does nothing or
/// the restart fails.
void restart_with_malloc_huge_pages(char** argv);

}  // namespace qjulia::cli
