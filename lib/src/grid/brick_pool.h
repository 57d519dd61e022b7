#pragma once
/// @file brick_pool.h
/// The memory of the sampled bricks and of their values. Bricks and value arrays are many small
/// blocks made and freed all through the sampling; from malloc they end up scattered over the
/// heap among the extraction's own blocks, so that once the bricks go the heap is full of holes
/// of a few KB and the mesh's arrays take fresh pages (which cost far more than writing them:
/// the kernel clears them, and a virtual machine's host may have to back them). From the pool
/// they come from large slabs, each size's freed blocks are reused, and when the last block is
/// freed every slab goes back to malloc at once: one free run that the mesh's arrays reuse.
///
/// That helps only when the thread that makes the mesh's arrays is the one whose malloc arena
/// holds the slabs: glibc gives each thread its own arena, and a worker's freed slabs cannot
/// hold the calling thread's arrays (two threads at 384 peaked 10% higher with the pool). So
/// the pool serves one-thread runs (pool_prefer()); otherwise blocks come from malloc.
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

/// What the pool holds: whether it serves blocks, its slabs, the blocks in use (either kind).
struct PoolUsage {
  bool pooled = false;
  std::size_t slabs = 0, blocks = 0;
};
PoolUsage pool_usage();

}  // namespace qjulia::detail
