// The brick pool (grid/brick_pool.h): blocks from slabs, reused, every slab unmapped with the
// last block, or with its own last block while draining; each thread on slabs of its own;
// sampling on one thread and on two uses it and gives the same bricks. Each test runs in its own
// process (the pool is the process's).
#include "grid/brick_pool.h"

#include <gtest/gtest.h>
#include <sys/mman.h>
#include <tbb/global_control.h>

#include <cerrno>
#include <cstdint>
#include <cstring>
#include <random>
#include <thread>
#include <vector>

#include "grid/bricks.h"
#include "grid/grid_impl.h"
#include "qjulia/field/params.h"
#include "qjulia/grid/sample.h"

namespace qjulia {
namespace {

using detail::pool_allocate;
using detail::pool_free;
using detail::pool_usage;

TEST(BrickPool, ServesFromSlabsReusesFreedBlocksAndHandsEverySlabBackWithTheLast) {
  const std::size_t sizes[] = {4, 64, 65, 700, 2916, detail::kPoolLargest};
  std::vector<std::pair<void*, std::size_t>> blocks;
  for (int i = 0; i < 6000; ++i) {
    const std::size_t n = sizes[i % 6];
    void* b = pool_allocate(n);
    ASSERT_EQ(reinterpret_cast<std::uintptr_t>(b) % 64, 0u) << n;
    std::memset(b, i & 0xff, n);
    blocks.push_back({b, n});
  }
  // 6000 blocks of 1.3 KB on average: several slabs of 2 MiB.
  EXPECT_GT(pool_usage().slabs, 2u);
  EXPECT_EQ(pool_usage().blocks, 6000u);
  // Each block still holds what was written to it: none overlaps another.
  for (std::size_t i = 0; i < blocks.size(); ++i)
    for (std::size_t k = 0; k < blocks[i].second; k += 61)
      ASSERT_EQ(static_cast<unsigned char*>(blocks[i].first)[k], i & 0xff) << i;
  // A freed block is the next one of its size (and of sizes that round to the same 64 bytes).
  void* freed = blocks[3].first;  // 700 bytes
  pool_free(freed, 700);
  const std::size_t slabs = pool_usage().slabs;
  EXPECT_EQ(pool_allocate(690), freed);
  EXPECT_EQ(pool_usage().slabs, slabs);
  for (const auto& [b, n] : blocks) pool_free(b, n);
  EXPECT_EQ(pool_usage().blocks, 0u);
  EXPECT_EQ(pool_usage().slabs, 0u);
  // Back to the kernel: the pages of the first and the last block are no longer mapped.
  const auto page_of = [](void* p) {
    return reinterpret_cast<void*>(reinterpret_cast<std::uintptr_t>(p) & ~std::uintptr_t{4095});
  };
  for (void* b : {blocks.front().first, blocks.back().first}) {
    unsigned char resident = 0;
    EXPECT_EQ(mincore(page_of(b), 4096, &resident), -1);
    EXPECT_EQ(errno, ENOMEM) << "the slab of " << b << " is still mapped";
  }
  EXPECT_THROW(pool_allocate(detail::kPoolLargest + 1), std::bad_alloc);
  EXPECT_EQ(pool_usage().blocks, 0u);
}

TEST(BrickPool, AFreshSlabsPagesAreAllPresentWhenItsFirstBlockIsServed) {
  void* b = pool_allocate(700);
  // The slab is aligned to its 2 MiB; its pages came in one call, not a fault each.
  void* slab = reinterpret_cast<void*>(reinterpret_cast<std::uintptr_t>(b) &
                                       ~((std::uintptr_t{2} << 20) - 1));
  std::vector<unsigned char> resident((std::size_t{2} << 20) / 4096);
  ASSERT_EQ(mincore(slab, std::size_t{2} << 20, resident.data()), 0);
  std::size_t present = 0;
  for (unsigned char c : resident) present += c & 1;
  EXPECT_EQ(present, resident.size());
  pool_free(b, 700);
  EXPECT_EQ(pool_usage().slabs, 0u);
}

TEST(BrickPool, ThreadsGetBlocksThatNeverOverlap) {
  std::vector<std::thread> threads;
  std::vector<int> bad(4, 0);
  for (int t = 0; t < 4; ++t)
    threads.emplace_back([t, &bad] {
      std::mt19937 rng(t);
      std::vector<std::pair<unsigned char*, std::size_t>> mine;
      for (int i = 0; i < 20000; ++i) {
        if (!mine.empty() && rng() % 3 == 0) {
          const std::size_t k = rng() % mine.size();
          auto [b, n] = mine[k];
          for (std::size_t j = 0; j < n; ++j) bad[t] += b[j] != static_cast<unsigned char>(t + n);
          pool_free(b, n);
          mine[k] = mine.back();
          mine.pop_back();
        } else {
          const std::size_t n = 1 + rng() % 3000;
          auto* b = static_cast<unsigned char*>(pool_allocate(n));
          std::memset(b, static_cast<unsigned char>(t + n), n);
          mine.push_back({b, n});
        }
      }
      for (auto [b, n] : mine) {
        for (std::size_t j = 0; j < n; ++j) bad[t] += b[j] != static_cast<unsigned char>(t + n);
        pool_free(b, n);
      }
    });
  for (auto& th : threads) th.join();
  for (int t = 0; t < 4; ++t) EXPECT_EQ(bad[t], 0) << "thread " << t;
  EXPECT_EQ(pool_usage().blocks, 0u);
  EXPECT_EQ(pool_usage().slabs, 0u);
}

// The bricks and their values, in order.
std::vector<float> contents(const detail::BrickList& bricks) {
  std::vector<float> out;
  for (const auto& b : bricks) {
    out.push_back(static_cast<float>(b->key));
    for (int p = 0; p < detail::kBrickPoints; ++p)
      if (b->known.test(p)) out.push_back(b->get(p));
    out.push_back(static_cast<float>(b->surface.count()));
  }
  return out;
}

TEST(BrickPool, DrainingUnmapsEachSlabWithItsLastBlockAndReusesNoFreedBlock) {
  // Blocks of 4 KB: 511 to a slab of 2 MiB (less its header); three slabs' worth.
  std::vector<void*> blocks;
  for (int i = 0; i < 1400; ++i) blocks.push_back(pool_allocate(detail::kPoolLargest));
  const std::size_t slabs = pool_usage().slabs;
  ASSERT_GE(slabs, 3u);
  auto slab_of = [](void* p) { return reinterpret_cast<std::uintptr_t>(p) >> 21; };
  auto mapped = [](void* p) {
    unsigned char resident = 0;
    void* page =
        reinterpret_cast<void*>(reinterpret_cast<std::uintptr_t>(p) & ~std::uintptr_t{4095});
    return mincore(page, 4096, &resident) == 0;
  };
  // A block freed before draining is reused; once draining, a freed block is not.
  pool_free(blocks[1], detail::kPoolLargest);
  EXPECT_EQ(pool_allocate(detail::kPoolLargest), blocks[1]);
  detail::pool_drain();
  pool_free(blocks[2], detail::kPoolLargest);
  void* fresh = pool_allocate(detail::kPoolLargest);
  EXPECT_NE(fresh, blocks[2]);
  EXPECT_NE(slab_of(fresh), slab_of(blocks[0])) << "draining makes new blocks on a new slab";
  blocks[2] = fresh;
  // The first slab's blocks freed: that slab is unmapped at once, the others stay.
  const auto first = slab_of(blocks[0]);
  std::vector<void*> rest;
  for (void* b : blocks)
    if (slab_of(b) == first)
      pool_free(b, detail::kPoolLargest);
    else
      rest.push_back(b);
  EXPECT_FALSE(mapped(blocks[0]));
  EXPECT_TRUE(mapped(rest.front()));
  EXPECT_EQ(pool_usage().blocks, rest.size());
  for (void* b : rest) pool_free(b, detail::kPoolLargest);
  EXPECT_EQ(pool_usage().slabs, 0u);
  // The last block ends the draining: freed blocks are reused again.
  void* a = pool_allocate(100);
  pool_free(a, 100);
  void* b = pool_allocate(100);
  EXPECT_EQ(a, b);
  pool_free(b, 100);
}

TEST(BrickPool, EachThreadTakesBlocksFromSlabsOfItsOwn) {
  std::vector<void*> mine(100), theirs(100);
  for (void*& b : mine) b = pool_allocate(640);
  std::thread other([&] {
    for (void*& b : theirs) b = pool_allocate(640);
  });
  other.join();
  auto slab_of = [](void* p) { return reinterpret_cast<std::uintptr_t>(p) >> 21; };
  for (void* b : theirs)
    for (void* m : mine) ASSERT_NE(slab_of(b), slab_of(m));
  EXPECT_EQ(pool_usage().slabs, 2u);
  // A block goes back to the slab it came from, whichever thread frees it.
  for (void* b : theirs) pool_free(b, 640);
  EXPECT_EQ(pool_usage().slabs, 1u);
  for (void* b : mine) pool_free(b, 640);
  EXPECT_EQ(pool_usage().slabs, 0u);
}

TEST(BrickPool, OneAndTwoThreadsSampleIntoThePoolAndGetTheSameBricks) {
  Params p = preset("classic-julia");
  p.resolution = 96;
  std::vector<float> one, two;
  {
    tbb::global_control single(tbb::global_control::max_allowed_parallelism, 1);
    const SampledGrid g = sample(p);
    const detail::PoolUsage u = pool_usage();
    EXPECT_GT(u.slabs, 0u);
    EXPECT_GE(u.blocks, g.impl().bricks.size());
    one = contents(g.impl().bricks);
  }
  EXPECT_EQ(pool_usage().blocks, 0u);
  EXPECT_EQ(pool_usage().slabs, 0u);
  {
    tbb::global_control pair(tbb::global_control::max_allowed_parallelism, 2);
    const SampledGrid g = sample(p);
    EXPECT_GT(pool_usage().slabs, 0u);
    EXPECT_GE(pool_usage().blocks, g.impl().bricks.size());
    two = contents(g.impl().bricks);
  }
  EXPECT_EQ(pool_usage().blocks, 0u);
  EXPECT_GT(one.size(), 1000u);
  EXPECT_EQ(one, two);
}

}  // namespace
}  // namespace qjulia
