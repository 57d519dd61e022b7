// Fresh memory asked for at once (base/pages.h, base/first_touch.h): the pages of a range are
// present after one call, and what was written there before is kept; a vector grown that way
// (its pages asked for in parallel blocks) keeps its elements and value-initialises the new
// ones.
#include "base/pages.h"

#include <gtest/gtest.h>
#include <sys/mman.h>
#include <unistd.h>

#include <array>
#include <cstdint>
#include <cstring>
#include <vector>

#include "base/first_touch.h"

namespace qjulia {
namespace {

// How many of the pages of [p, p + bytes) (p page-aligned) are resident.
std::size_t resident_pages(const void* p, std::size_t bytes) {
  const std::size_t page = static_cast<std::size_t>(sysconf(_SC_PAGESIZE));
  std::vector<unsigned char> in((bytes + page - 1) / page);
  EXPECT_EQ(mincore(const_cast<void*>(p), bytes, in.data()), 0);
  std::size_t n = 0;
  for (unsigned char c : in) n += c & 1;
  return n;
}

TEST(Pages, PopulatingMakesEveryPageOfTheRangePresentAndKeepsWhatIsWritten) {
  const std::size_t page = static_cast<std::size_t>(sysconf(_SC_PAGESIZE));
  const std::size_t pages = 64;
  auto* m = static_cast<unsigned char*>(
      mmap(nullptr, pages * page, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0));
  ASSERT_NE(m, MAP_FAILED);
  detail::advise_huge_pages(m, pages * page);
  // Fresh: nothing resident but the page written.
  m[page + 100] = 0xab;
  EXPECT_EQ(resident_pages(m, pages * page), 1u);
  // A range from the middle of that page to the middle of page 40.
  ASSERT_TRUE(detail::populate_pages(m + page + 50, 39 * page));
  EXPECT_EQ(m[page + 100], 0xab);
  EXPECT_EQ(resident_pages(m, pages * page), 40u);  // pages 1 .. 40
  EXPECT_EQ(resident_pages(m, page), 0u);
  EXPECT_EQ(resident_pages(m + page, 40 * page), 40u);
  for (std::size_t i = 0; i < pages * page; ++i) ASSERT_EQ(m[i], i == page + 100 ? 0xab : 0) << i;
  // A range beyond the mapping is refused.
  ASSERT_EQ(munmap(m + 48 * page, 16 * page), 0);
  EXPECT_FALSE(detail::populate_pages(m + 40 * page, 16 * page));
  EXPECT_TRUE(detail::populate_pages(m, 0));
  munmap(m, 48 * page);
}

TEST(Pages, AVectorGrownFirstTouchedKeepsItsElementsAndZeroesTheNewOnes) {
  for (std::size_t n : {std::size_t{1000}, std::size_t{3} << 20}) {
    std::vector<std::array<float, 3>> v(777, {1.5f, -2.f, 3.f});
    detail::resize_first_touched(v, n);
    ASSERT_EQ(v.size(), n);
    for (std::size_t i = 0; i < n; ++i) {
      const std::array<float, 3> want =
          i < 777 ? std::array<float, 3>{1.5f, -2.f, 3.f} : std::array<float, 3>{0, 0, 0};
      ASSERT_EQ(v[i], want) << i << " of " << n;
    }
    // Shrinking keeps the first elements.
    detail::resize_first_touched(v, 10);
    ASSERT_EQ(v.size(), 10u);
    EXPECT_EQ(v[9], (std::array<float, 3>{1.5f, -2.f, 3.f}));
  }
}

}  // namespace
}  // namespace qjulia
