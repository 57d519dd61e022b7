// How the qjulia command sets up malloc: transparent huge pages (it restarts itself once with
// glibc's `glibc.malloc.hugetlb=1` tunable, which glibc reads only at a process's start) and
// fixed thresholds for mapping and trimming.
#pragma once

#include <string>

namespace qjulia::cli {

/// Where the machine's transparent huge pages stand for this process: "on" (malloc asks for them),
/// or "off (...)" with the reason.
std::string malloc_huge_pages_state();

/// When the kernel gives transparent huge pages only to memory that asks for them (mode
/// `madvise`), they pay here (`huge_page_choice()`, qjulia/base/memory.h: QJULIA_HUGE_PAGES and
/// the machine's free page reporting) and GLIBC_TUNABLES has not decided otherwise, runs this
/// program again (same pid, arguments and environment, plus the tunable) so that malloc asks for
/// them: on a virtual machine a page fault costs several microseconds, and a run touches every
/// page of its memory once. When they do not pay and the kernel's mode is `always`, turns them
/// off for this process (`PR_SET_THP_DISABLE`). Returns (and the run goes on as it is) when it
/// does nothing or the restart fails. Uses only the C library, so that it can run before the
/// libraries' initialisers (see `restart_early`).
void restart_with_malloc_huge_pages(char** argv);

/// `restart_with_malloc_huge_pages` for the commands that do real work (`mesh`, `compare`,
/// `render`, `experiment`, `bench`, `explore`); the quick ones are left alone. Meant for the
/// program's `.preinit_array`, which the dynamic loader runs before any shared library's
/// initialiser: the process that restarts then does not pay for those (about 12 ms: libhwy's
/// timer calibration, which hwy_timer.cpp now skips, OpenSSL's configuration, TBB, the C++
/// runtime).
void restart_early(int argc, char** argv, char** envp);

/// Fixes malloc's thresholds: blocks up to 32 MiB come from the heap, and the heap hands its free
/// top back to the system only past 128 MiB. glibc's defaults map every block over 128 KiB on
/// its own until the process has freed one, and trim the top past 256 KiB: each pass of a run
/// then faults its pages in afresh (classic-julia at 256 on one thread: ~5,600 page faults
/// instead of ~1,400). The runs that free much trim on their own (see `return_free_memory`).
/// Also sets the top pad to 64 MiB, so that a worker thread's heap (64 MiB of address space) is
/// made accessible whole when it is made: glibc's 128 KiB let it grow page by page, one
/// `mprotect` each (14,700 in newton-cubic at 512 on two threads), each holding the process's
/// memory map against the other thread's page faults (two threads took 4.1 s instead of 3.7).
/// The pad is address space, not memory: pages count only once touched.
/// A setting that GLIBC_TUNABLES or glibc's MALLOC_*_ variables make is left alone.
void fix_malloc_thresholds();

/// What `fix_malloc_thresholds` left in force, observed: whether a block of 16 MiB comes from the
/// heap, whether a new thread's heap is made whole at once, and which settings the user made.
std::string malloc_thresholds_state();

}  // namespace qjulia::cli
