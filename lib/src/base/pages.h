#pragma once
// Fresh memory from the kernel: how its pages are asked for. A fresh page costs far more than
// writing it (the kernel clears it, and a virtual machine's host may have to back it); asking
// for a range's pages at once saves the fault of each page.
#include <cstddef>

namespace qjulia::detail {

/// Asks the kernel for huge pages in [p, p + bytes) when they pay (huge_page_choice()), and
/// for none otherwise: a hint, which the kernel may refuse.
void advise_huge_pages(void* p, std::size_t bytes) noexcept;

/// Makes the pages of [p, p + bytes) (within one mapping of this process, writable) present
/// and writable in one call (MADV_POPULATE_WRITE), without changing their contents; false when
/// the kernel cannot (before Linux 5.14), and the pages then come one fault at a time as before.
bool populate_pages(void* p, std::size_t bytes) noexcept;

}  // namespace qjulia::detail
