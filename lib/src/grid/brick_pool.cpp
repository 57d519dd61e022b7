#include "grid/brick_pool.h"

#include <immintrin.h>
#include <sys/mman.h>

#include <atomic>
#include <cstdint>
#include <mutex>
#include <new>
#include <vector>

// Under AddressSanitizer a free block is poisoned, so that a brick used after it was freed is
// still caught.
#if defined(__SANITIZE_ADDRESS__)
#include <sanitizer/asan_interface.h>
#define QJULIA_POISON(p, n) ASAN_POISON_MEMORY_REGION(p, n)
#define QJULIA_UNPOISON(p, n) ASAN_UNPOISON_MEMORY_REGION(p, n)
#else
#define QJULIA_POISON(p, n) ((void)(p), (void)(n))
#define QJULIA_UNPOISON(p, n) ((void)(p), (void)(n))
#endif

namespace qjulia::detail {
namespace {

constexpr std::size_t kAlign = 64;
constexpr std::size_t kClasses = kPoolLargest / kAlign;
// A slab is one huge page: mapped on its own, aligned to its size, so the kernel can back it
// with one huge page, and unmapped whole.
constexpr std::size_t kSlab = std::size_t{2} << 20;
static_assert(kSlab % kAlign == 0 && kSlab >= kPoolLargest);

// A fresh slab from the kernel (twice its size mapped, the unaligned ends unmapped), or null.
void* map_slab() {
  void* p = mmap(nullptr, 2 * kSlab, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  if (p == MAP_FAILED) return nullptr;
  const auto first = reinterpret_cast<std::uintptr_t>(p);
  const auto at = (first + kSlab - 1) & ~(kSlab - 1);
  if (at > first) munmap(p, at - first);
  if (at + kSlab < first + 2 * kSlab)
    munmap(reinterpret_cast<void*>(at + kSlab), first + 2 * kSlab - (at + kSlab));
  madvise(reinterpret_cast<void*>(at), kSlab, MADV_HUGEPAGE);  // a hint: may be refused
  return reinterpret_cast<void*>(at);
}

struct FreeBlock {
  FreeBlock* next;
};

// The first kAlign bytes of a slab: its blocks in use, and its place in the pool's list.
struct SlabHeader {
  std::uint32_t live = 0;
  std::uint32_t index = 0;
};
static_assert(sizeof(SlabHeader) <= kAlign);

SlabHeader& header_of(void* block) {
  return *reinterpret_cast<SlabHeader*>(reinterpret_cast<std::uintptr_t>(block) & ~(kSlab - 1));
}

// A lock held for a few instructions: a thread that finds it taken spins instead of sleeping
// (std::mutex made two threads' sampling 7% slower).
class SpinLock {
 public:
  void lock() noexcept {
    while (locked_.exchange(true, std::memory_order_acquire))
      while (locked_.load(std::memory_order_relaxed)) _mm_pause();
  }
  void unlock() noexcept { locked_.store(false, std::memory_order_release); }

 private:
  std::atomic<bool> locked_{false};
};

// One pool for the process: the bricks of several grids (tests, the explorer's previews) share
// it, and its slabs go when none of their blocks is in use.
struct Pool {
  // The blocks in use (either kind) times 2, plus 1 while blocks come from the pool. The mode
  // changes only when no block is in use, so a block in use was made in the current mode.
  std::atomic<std::uint64_t> state{0};
  SpinLock lock;
  std::vector<void*> slabs;
  char* next = nullptr;  // the unused rest of the newest slab
  char* end = nullptr;
  FreeBlock* free[kClasses] = {};
  // Draining (drain()): freed blocks are not reused, and a slab is unmapped once its last block
  // is freed; until no block of the pool is in use.
  bool draining = false;

  static std::size_t class_of(std::size_t bytes) { return (bytes + kAlign - 1) / kAlign - 1; }

  void* allocate(std::size_t bytes) {
    if (bytes == 0 || bytes > kPoolLargest) throw std::bad_alloc();
    const std::uint64_t s = state.fetch_add(2, std::memory_order_acq_rel);
    try {
      return (s & 1) ? from_slabs(bytes) : ::operator new(bytes);
    } catch (...) {
      release(nullptr, 0, s & 1);  // not made after all
      throw;
    }
  }

  void* from_slabs(std::size_t bytes) {
    const std::size_t c = class_of(bytes), size = (c + 1) * kAlign;
    std::unique_lock<SpinLock> held(lock);
    if (free[c]) {
      void* block = free[c];
      QJULIA_UNPOISON(block, size);
      free[c] = free[c]->next;
      ++header_of(block).live;
      return block;
    }
    if (next == nullptr || static_cast<std::size_t>(end - next) < size) {
      // A new slab, mapped with the lock released.
      held.unlock();
      void* slab = map_slab();
      if (!slab) throw std::bad_alloc();
      held.lock();
      try {
        slabs.push_back(slab);
      } catch (...) {
        munmap(slab, kSlab);
        throw;
      }
      new (slab) SlabHeader{0, static_cast<std::uint32_t>(slabs.size() - 1)};
      next = static_cast<char*>(slab) + kAlign;
      end = static_cast<char*>(slab) + kSlab;
    }
    void* block = next;
    next += size;
    ++header_of(block).live;
    return block;
  }

  // Unmaps a slab none of whose blocks is in use (the lock held).
  void unmap(SlabHeader& h) noexcept {
    char* const slab = reinterpret_cast<char*>(&h);
    const std::uint32_t i = h.index;
    slabs[i] = slabs.back();
    static_cast<SlabHeader*>(slabs[i])->index = i;
    slabs.pop_back();
    if (next && next >= slab && next <= slab + kSlab) next = end = nullptr;
    QJULIA_UNPOISON(slab, kSlab);
    munmap(slab, kSlab);
  }

  void drain() noexcept {
    std::lock_guard<SpinLock> held(lock);
    if (!(state.load(std::memory_order_acquire) & 1) || slabs.empty()) return;
    draining = true;
    for (FreeBlock*& head : free) head = nullptr;  // their blocks stay free, and poisoned
    next = end = nullptr;
    for (std::size_t i = slabs.size(); i-- > 0;) {
      SlabHeader& h = *static_cast<SlabHeader*>(slabs[i]);
      if (h.live == 0) unmap(h);
    }
  }

  void free_block(void* block, std::size_t bytes) noexcept {
    if (!block) return;
    // This block is in use, so the mode is the one it was made in.
    const bool pooled = state.load(std::memory_order_acquire) & 1;
    if (!pooled) ::operator delete(block);
    release(block, bytes, pooled);
  }

  // One block fewer in use; `block` (when given) goes to its free list. The last block of the
  // pool hands every slab back to the kernel.
  void release(void* block, std::size_t bytes, bool pooled) noexcept {
    if (!pooled) {
      state.fetch_sub(2, std::memory_order_acq_rel);
      return;
    }
    std::lock_guard<SpinLock> held(lock);
    if (block) {
      const std::size_t c = class_of(bytes);
      SlabHeader& h = header_of(block);
      --h.live;
      if (!draining) {
        auto* f = static_cast<FreeBlock*>(block);
        f->next = free[c];
        free[c] = f;
      }
      QJULIA_POISON(block, (c + 1) * kAlign);
      if (draining && h.live == 0) unmap(h);
    }
    if (state.fetch_sub(2, std::memory_order_acq_rel) >> 1 != 1) return;
    for (void* slab : slabs) {
      QJULIA_UNPOISON(slab, kSlab);
      munmap(slab, kSlab);
    }
    slabs.clear();
    slabs.shrink_to_fit();
    next = end = nullptr;
    for (FreeBlock*& head : free) head = nullptr;
    draining = false;
  }

  bool prefer(bool use_pool) {
    std::uint64_t s = state.load(std::memory_order_acquire);
    while (s >> 1 == 0 && (s & 1) != static_cast<std::uint64_t>(use_pool))
      if (state.compare_exchange_weak(s, use_pool ? 1 : 0, std::memory_order_acq_rel)) break;
    return state.load(std::memory_order_acquire) & 1;
  }
};

Pool& pool() {
  static Pool* p = new Pool;  // never destroyed: bricks may outlive static destruction order
  return *p;
}

}  // namespace

void* pool_allocate(std::size_t bytes) { return pool().allocate(bytes); }

void pool_free(void* block, std::size_t bytes) noexcept { pool().free_block(block, bytes); }

bool pool_prefer(bool use_pool) { return pool().prefer(use_pool); }

void pool_drain() noexcept { pool().drain(); }

PoolUsage pool_usage() {
  Pool& p = pool();
  std::lock_guard<SpinLock> held(p.lock);
  const std::uint64_t s = p.state.load(std::memory_order_acquire);
  return {static_cast<bool>(s & 1), p.slabs.size(), static_cast<std::size_t>(s >> 1)};
}

}  // namespace qjulia::detail
