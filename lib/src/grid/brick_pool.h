#pragma once
/// @file brick_pool.h
/// The memory of the sampled bricks and of their values. Bricks and value arrays are many small
/// blocks made and freed all through the sampling; from malloc they end up scattered over the
/// heap among the extraction's own blocks (and, on several threads, in each thread's arena), so
/// that once the bricks go the heap is full of holes of a few KB that the mesh's arrays cannot
/// use: those take fresh pages, which cost far more than writing them (the kernel clears them,
/// about 2 ms a MB on the project's virtual machine for pages long free), and handing the holes
/// back (malloc_trim) takes one madvise each. From the pool they come from slabs of 2 MiB
/// each (one huge page where the process asks for them, huge_page_choice()), mapped on their own;
/// each thread takes blocks from its own stripe of slabs under its own lock, each size's freed
/// blocks are reused, and during the extraction (pool_drain()) each slab is unmapped as soon as its
/// last brick goes. The mesh's arrays, made meanwhile, get those pages from the kernel: pages in
/// use a moment before, which it clears at the speed of memory.
#include <cstddef>

namespace qjulia::detail {

/// A block of at least `bytes` (at most kPoolLargest), aligned to 64 bytes. Thread-safe.
void* pool_allocate(std::size_t bytes);
/// Frees a block from pool_allocate() with the same `bytes`. Thread-safe.
void pool_free(void* block, std::size_t bytes) noexcept;

/// The largest block the pool gives.
constexpr std::size_t kPoolLargest = 4096;

/// From now on, in each thread's stripe of slabs until no block of that stripe is in use, freed
/// blocks are not reused and each slab is unmapped as soon as its last block is freed: for the
/// extraction, which frees the bricks brick by brick and makes none.
void pool_drain() noexcept;

/// What the pool holds: its slabs and the blocks in use.
struct PoolUsage {
  std::size_t slabs = 0, blocks = 0;
};
PoolUsage pool_usage();

}  // namespace qjulia::detail
