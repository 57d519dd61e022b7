#include "grid/brick_pool.h"

#include <immintrin.h>
#include <sys/mman.h>

#include <atomic>
#include <cstdint>
#include <mutex>
#include <new>
#include <vector>

#include "base/pages.h"

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
// with one huge page where this process asks for them, and unmapped whole.
constexpr std::size_t kSlab = std::size_t{2} << 20;
static_assert(kSlab % kAlign == 0 && kSlab >= kPoolLargest + kAlign);
// Threads take stripes in turn; more threads than stripes share them.
constexpr std::uint32_t kStripes = 64;

// A fresh slab from the kernel (twice its size mapped, the unaligned ends unmapped), or null.
void* map_slab() {
  void* p = mmap(nullptr, 2 * kSlab, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  if (p == MAP_FAILED) return nullptr;
  const auto first = reinterpret_cast<std::uintptr_t>(p);
  const auto at = (first + kSlab - 1) & ~(kSlab - 1);
  if (at > first) munmap(p, at - first);
  if (at + kSlab < first + 2 * kSlab)
    munmap(reinterpret_cast<void*>(at + kSlab), first + 2 * kSlab - (at + kSlab));
  advise_huge_pages(reinterpret_cast<void*>(at), kSlab);
  // Its pages at once: the pool carves a slab into blocks from its start and maps the next only
  // when less than a block is left, so all of it is used but a stripe's newest slab (at most 2
  // MiB a thread present before it is used).
  populate_pages(reinterpret_cast<void*>(at), kSlab);
  return reinterpret_cast<void*>(at);
}

struct FreeBlock {
  FreeBlock* next;
};

// The first kAlign bytes of a slab: its blocks in use, its place in its stripe's list, and the
// stripe.
struct SlabHeader {
  std::uint32_t live = 0;
  std::uint32_t index = 0;
  std::uint32_t stripe = 0;
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

// The slabs of one thread (or of the threads that share its stripe), under its own lock: a
// thread takes blocks from its stripe, and a block goes back to the stripe of its slab. Every
// member is used with the lock held.
struct alignas(64) Stripe {
  SpinLock lock;
  std::uint32_t id = 0;
  std::vector<void*> slabs;
  char* next = nullptr;  // the unused rest of the newest slab
  char* end = nullptr;
  FreeBlock* free[kClasses] = {};
  std::size_t live = 0;  // blocks in use, over the slabs
  // Draining (drain()): freed blocks are not reused, and a slab is unmapped once its last block
  // is freed; until no block of the stripe is in use.
  bool draining = false;

  static std::size_t class_of(std::size_t bytes) { return (bytes + kAlign - 1) / kAlign - 1; }

  void* allocate(std::size_t bytes) {
    const std::size_t c = class_of(bytes), size = (c + 1) * kAlign;
    void* block;
    if (free[c]) {
      block = free[c];
      QJULIA_UNPOISON(block, size);
      free[c] = free[c]->next;
    } else {
      if (next == nullptr || static_cast<std::size_t>(end - next) < size) {
        // A new slab.
        void* slab = map_slab();
        if (!slab) throw std::bad_alloc();
        try {
          slabs.push_back(slab);
        } catch (...) {
          munmap(slab, kSlab);
          throw;
        }
        new (slab) SlabHeader{0, static_cast<std::uint32_t>(slabs.size() - 1), id};
        next = static_cast<char*>(slab) + kAlign;
        end = static_cast<char*>(slab) + kSlab;
      }
      block = next;
      next += size;
    }
    ++header_of(block).live;
    ++live;
    return block;
  }

  // A block of this stripe's slabs goes back. The last block in use hands every slab back to the
  // kernel.
  void free_block(void* block, std::size_t bytes) noexcept {
    const std::size_t c = class_of(bytes);
    SlabHeader& h = header_of(block);
    --h.live;
    --live;
    if (!draining) {
      auto* f = static_cast<FreeBlock*>(block);
      f->next = free[c];
      free[c] = f;
    }
    QJULIA_POISON(block, (c + 1) * kAlign);
    if (live == 0) {
      release_all();
    } else if (draining && h.live == 0) {
      unmap(h);
    }
  }

  // Unmaps a slab none of whose blocks is in use.
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

  void release_all() noexcept {
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

  void drain() noexcept {
    if (slabs.empty()) return;
    draining = true;
    for (FreeBlock*& head : free) head = nullptr;  // their blocks stay free, and poisoned
    next = end = nullptr;
    for (std::size_t i = slabs.size(); i-- > 0;) {
      SlabHeader& h = *static_cast<SlabHeader*>(slabs[i]);
      if (h.live == 0) unmap(h);
    }
  }
};

// One pool for the process: the bricks of several grids (tests, the explorer's previews) share
// it.
struct Pool {
  std::atomic<std::uint32_t> turn{0};
  Stripe stripes[kStripes];

  Pool() {
    for (std::uint32_t i = 0; i < kStripes; ++i) stripes[i].id = i;
  }

  Stripe& mine() {
    thread_local const std::uint32_t s = turn.fetch_add(1, std::memory_order_relaxed) % kStripes;
    return stripes[s];
  }

  void* allocate(std::size_t bytes) {
    if (bytes == 0 || bytes > kPoolLargest) throw std::bad_alloc();
    Stripe& s = mine();
    std::lock_guard<SpinLock> held(s.lock);
    return s.allocate(bytes);
  }

  void free_block(void* block, std::size_t bytes) noexcept {
    if (!block) return;
    // This block is in use, so its slab is mapped.
    Stripe& s = stripes[header_of(block).stripe];
    std::lock_guard<SpinLock> held(s.lock);
    s.free_block(block, bytes);
  }

  template <class F>
  void with_every_stripe(F&& f) {
    for (Stripe& s : stripes) s.lock.lock();
    f();
    for (Stripe& s : stripes) s.lock.unlock();
  }

  void drain() noexcept {
    for (Stripe& s : stripes) {
      std::lock_guard<SpinLock> held(s.lock);
      s.drain();
    }
  }

  PoolUsage usage() {
    PoolUsage u;
    with_every_stripe([&] {
      for (const Stripe& s : stripes) {
        u.slabs += s.slabs.size();
        u.blocks += s.live;
      }
    });
    return u;
  }
};

Pool& pool() {
  static Pool* p = new Pool;  // never destroyed: bricks may outlive static destruction order
  return *p;
}

}  // namespace

void* pool_allocate(std::size_t bytes) { return pool().allocate(bytes); }

void pool_free(void* block, std::size_t bytes) noexcept { pool().free_block(block, bytes); }

void pool_drain() noexcept { pool().drain(); }

PoolUsage pool_usage() { return pool().usage(); }

}  // namespace qjulia::detail
