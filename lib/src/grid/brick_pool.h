#pragma once
/// @file brick_pool.h
/// The memory of the sampled bricks and of their values. Bricks and value arrays are many small
/// blocks made and freed all through the sampling; from malloc they end up scattered over the
/// heap among the extraction's own blocks, so that once the bricks go the heap is full of holes
/// of a few KB and the mesh's arrays take fresh pages (which cost far more than writing them:
/// the kernel clears them, and a virtual machine's host may have to back them). From the pool
/// they come from slabs of one huge page each, mapped on their own; each size's freed blocks are
/// reused, and when the last block is freed every slab is unmapped at once. The mesh's arrays,
/// made next, then get those pages from the kernel: pages in use a moment before, which it
/// clears at the speed of memory, where pages long free cost about 2 ms a MB on the project's
/// virtual machine (newton-cubic at 512 on one thread: 7.19 s instead of 7.53 with the slabs
/// from malloc, classic-julia 1.10 s instead of 1.20).
///
/// The pool serves one-thread runs (pool_prefer()); otherwise blocks come from malloc: on two
/// threads the one lock made the sampling slower, and the bricks kept until the last one goes
/// raised newton-cubic's peak at 1024 above its bound.
#include <cstddef>

namespace qjulia::detail {

/// A block of at least `bytes` (at most kPoolLargest), aligned to 64 bytes in the pool and as
/// `operator new` aligns otherwise. Thread-safe.
void* pool_allocate(std::size_t bytes);
/// Frees a block from pool_allocate() with the same `bytes`. Thread-safe.
void pool_free(void* block, std::size_t bytes) noexcept;

/// The largest block the pool gives.
constexpr std::size_t kPoolLargest = 4096;

/// Whether blocks come from the pool from now on. Takes effect only when no block is in use
/// (a block goes back where it came from); returns whether the pool is in use after the call.
bool pool_prefer(bool use_pool);

/// From now until no block of the pool is in use, freed blocks are not reused and each slab is
/// unmapped as soon as its last block is freed: for the extraction, which frees the bricks
/// brick by brick and makes none.
void pool_drain() noexcept;

/// What the pool holds: whether it serves blocks, its slabs, the blocks in use (either kind).
struct PoolUsage {
  bool pooled = false;
  std::size_t slabs = 0, blocks = 0;
};
PoolUsage pool_usage();

}  // namespace qjulia::detail
