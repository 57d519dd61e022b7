#include "grid/brick_pool.h"

#include <immintrin.h>

#include <atomic>
#include <cstdint>
#include <cstdlib>
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
constexpr std::size_t kSlab = std::size_t{1} << 20;

struct FreeBlock {
  FreeBlock* next;
};

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
  std::vector<void*> slabs;  // as malloc gave them
  char* next = nullptr;      // the unused rest of the newest slab
  char* end = nullptr;
  FreeBlock* free[kClasses] = {};

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
      return block;
    }
    if (next == nullptr || static_cast<std::size_t>(end - next) < size) {
      // A new slab, taken from malloc with the lock released (its first page is faulted in).
      held.unlock();
      void* slab = std::malloc(kSlab + kAlign);
      if (!slab) throw std::bad_alloc();
      held.lock();
      try {
        slabs.push_back(slab);
      } catch (...) {
        std::free(slab);
        throw;
      }
      const auto at = (reinterpret_cast<std::uintptr_t>(slab) + kAlign - 1) & ~(kAlign - 1);
      next = reinterpret_cast<char*>(at);
      end = next + kSlab;
    }
    void* block = next;
    next += size;
    return block;
  }

  void free_block(void* block, std::size_t bytes) noexcept {
    if (!block) return;
    // This block is in use, so the mode is the one it was made in.
    const bool pooled = state.load(std::memory_order_acquire) & 1;
    if (!pooled) ::operator delete(block);
    release(block, bytes, pooled);
  }

  // One block fewer in use; `block` (when given) goes to its free list. The last block of the
  // pool takes every slab back to malloc (which joins neighbouring ones into one free run).
  void release(void* block, std::size_t bytes, bool pooled) noexcept {
    if (!pooled) {
      state.fetch_sub(2, std::memory_order_acq_rel);
      return;
    }
    std::lock_guard<SpinLock> held(lock);
    if (block) {
      auto* f = static_cast<FreeBlock*>(block);
      const std::size_t c = class_of(bytes);
      f->next = free[c];
      free[c] = f;
      QJULIA_POISON(block, (c + 1) * kAlign);
    }
    if (state.fetch_sub(2, std::memory_order_acq_rel) >> 1 != 1) return;
    for (void* slab : slabs) {
      QJULIA_UNPOISON(slab, kSlab + kAlign);
      std::free(slab);
    }
    slabs.clear();
    slabs.shrink_to_fit();
    next = end = nullptr;
    for (FreeBlock*& head : free) head = nullptr;
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

PoolUsage pool_usage() {
  Pool& p = pool();
  std::lock_guard<SpinLock> held(p.lock);
  const std::uint64_t s = p.state.load(std::memory_order_acquire);
  return {static_cast<bool>(s & 1), p.slabs.size(), static_cast<std::size_t>(s >> 1)};
}

}  // namespace qjulia::detail
