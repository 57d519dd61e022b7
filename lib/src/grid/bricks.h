#pragma once
// Bricks: the unit of sampling, meshing and parallel work. A brick is the cube of 8^3 cells
// whose lowest cell is 8 * (bx, by, bz) (a VDB leaf); it holds the values of its 9^3 corner
// points (its own 8^3 and the first layer of its upper neighbours, evaluated again so every
// brick can decide its cells alone), which of them are known, and which of its cells carry the
// surface. Cells range over -1 .. points - 1 per axis, so bricks start at -1.
#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <vector>

#include "grid/brick_pool.h"
#include "qjulia/field/classify.h"
#include "qjulia/grid/sample.h"

namespace qjulia::detail {

constexpr int kBrick = 8;          ///< cells per brick side
constexpr int kSide = kBrick + 1;  ///< points per brick side
constexpr int kBrickPoints = kSide * kSide * kSide;
constexpr int kBrickCells = kBrick * kBrick * kBrick;

/// Brick coordinates: brick (bx, by, bz) has cells 8 bx .. 8 bx + 7 etc.
struct BrickCoord {
  int x = 0, y = 0, z = 0;
};

/// The bits of each coordinate's field in a brick key (z lowest, then y, then x).
constexpr int kKeyBits = 21;
/// A 64-bit key per brick, ordered x-major; bricks from -1 to 2^21 - 2 per axis.
inline std::uint64_t brick_key(int bx, int by, int bz) {
  return (static_cast<std::uint64_t>(bx + 1) << (2 * kKeyBits)) |
         (static_cast<std::uint64_t>(by + 1) << kKeyBits) | static_cast<std::uint64_t>(bz + 1);
}
inline BrickCoord brick_of_key(std::uint64_t key) {
  constexpr std::uint64_t m = (std::uint64_t{1} << kKeyBits) - 1;
  return {static_cast<int>((key >> (2 * kKeyBits)) & m) - 1,
          static_cast<int>((key >> kKeyBits) & m) - 1, static_cast<int>(key & m) - 1};
}

/// Index of local point (i, j, k), 0..8 each.
inline int point_index(int i, int j, int k) { return (i * kSide + j) * kSide + k; }
/// Index of local cell (i, j, k), 0..7 each.
inline int cell_index(int i, int j, int k) { return (i * kBrick + j) * kBrick + k; }

/// The set bits of x, inline on every x86-64 (the baseline has no POPCNT instruction, and the
/// library call costs more than these few operations).
inline int popcount64(std::uint64_t x) {
  x = x - ((x >> 1) & 0x5555555555555555ull);
  x = (x & 0x3333333333333333ull) + ((x >> 2) & 0x3333333333333333ull);
  x = (x + (x >> 4)) & 0x0f0f0f0f0f0f0f0full;
  return static_cast<int>((x * 0x0101010101010101ull) >> 56);
}

/// Calls f(offset + i) for each set bit i of `bits`, lowest first.
template <class F>
inline void for_each_bit(std::uint64_t bits, int offset, F&& f) {
  for (; bits; bits &= bits - 1) f(offset + __builtin_ctzll(bits));
}

/// A fixed-size bit set.
template <int N>
struct Bits {
  static constexpr int kWords = (N + 63) / 64;
  std::uint64_t w[kWords] = {};
  bool test(int i) const { return (w[i >> 6] >> (i & 63)) & 1u; }
  void set(int i) { w[i >> 6] |= std::uint64_t{1} << (i & 63); }
  /// Calls f(i) for each member i, in increasing order.
  template <class F>
  void for_each(F&& f) const {
    for (int k = 0; k < kWords; ++k) for_each_bit(w[k], 64 * k, f);
  }
  bool any() const {
    for (std::uint64_t x : w)
      if (x) return true;
    return false;
  }
  std::size_t count() const {
    std::size_t n = 0;
    for (std::uint64_t x : w) n += static_cast<std::size_t>(popcount64(x));
    return n;
  }
  friend Bits operator&(const Bits& a, const Bits& b) {
    Bits r;
    for (int i = 0; i < kWords; ++i) r.w[i] = a.w[i] & b.w[i];
    return r;
  }
  friend Bits operator|(const Bits& a, const Bits& b) {
    Bits r;
    for (int i = 0; i < kWords; ++i) r.w[i] = a.w[i] | b.w[i];
    return r;
  }
  friend Bits operator~(const Bits& a) {
    Bits r;
    for (int i = 0; i < kWords; ++i) r.w[i] = ~a.w[i];
    if (N % 64) r.w[kWords - 1] &= (std::uint64_t{1} << (N % 64)) - 1;
    return r;
  }
};

/// r[p] = b[p + k] where 0 <= p + k < N, else 0.
template <int N>
Bits<N> shifted(const Bits<N>& b, int k) {
  Bits<N> r;
  constexpr int W = Bits<N>::kWords;
  if (k >= 0) {
    const int ws = k / 64, bs = k % 64;
    for (int i = 0; i + ws < W; ++i) {
      std::uint64_t v = b.w[i + ws] >> bs;
      if (bs && i + ws + 1 < W) v |= b.w[i + ws + 1] << (64 - bs);
      r.w[i] = v;
    }
  } else {
    const int m = -k, ws = m / 64, bs = m % 64;
    for (int i = W - 1; i >= ws; --i) {
      std::uint64_t v = b.w[i - ws] << bs;
      if (bs && i - ws - 1 >= 0) v |= b.w[i - ws - 1] >> (64 - bs);
      r.w[i] = v;
    }
    if (N % 64) r.w[W - 1] &= (std::uint64_t{1} << (N % 64)) - 1;
  }
  return r;
}

/// An array of n floats from the brick pool (n fixed when made), or none.
class PoolFloats {
 public:
  PoolFloats() = default;
  PoolFloats(const PoolFloats&) = delete;
  PoolFloats& operator=(const PoolFloats&) = delete;
  ~PoolFloats() { reset(); }
  /// Frees the array and makes one of n floats (n >= 1), uninitialised.
  void make(std::size_t n) {
    reset();
    data_ = static_cast<float*>(pool_allocate(n * sizeof(float)));
    size_ = static_cast<std::uint32_t>(n);
  }
  void reset() noexcept {
    pool_free(data_, size_ * sizeof(float));
    data_ = nullptr;
    size_ = 0;
  }
  explicit operator bool() const { return data_ != nullptr; }
  float& operator[](std::size_t i) const { return data_[i]; }
  float* get() const { return data_; }

 private:
  float* data_ = nullptr;
  std::uint32_t size_ = 0;
};

/// One brick of the sampled grid. The fields a neighbour reads (where it is, which points are
/// known, their values) come first, in the brick's first cache lines.
struct Brick {
  // From the brick pool, as are its values.
  static void* operator new(std::size_t bytes) { return pool_allocate(bytes); }
  static void operator delete(void* p, std::size_t bytes) noexcept { pool_free(p, bytes); }

  BrickCoord at;
  std::uint64_t key = 0;
  Bits<kBrickPoints> known;  ///< points whose value is known

  /// F at known point p (the virtual value outside the grid or a clip).
  float get(int p) const { return *where(p); }
  /// Where the value of known point p is kept, in either form.
  const float* where(int p) const {
    if (full) return &full[p];
    const std::size_t r = rank[p >> 6];
    const std::uint64_t below = known.w[p >> 6] & ((std::uint64_t{1} << (p & 63)) - 1);
    return &packed[r + static_cast<std::size_t>(popcount64(below))];
  }
  /// Asks for the cache lines where() reads before the values (a neighbour's, ahead of a visit).
  void prefetch_where() const {
    __builtin_prefetch(&full);
    __builtin_prefetch(&rank[sizeof rank / sizeof rank[0] - 1]);
  }
  /// Where the value of point p goes (the brick must be unpacked).
  float* slot(int p) { return &full[p]; }
  /// Values as an array of all 9^3 points, for sampling the brick.
  void unpack();
  /// Values of the known points only (about a third of the points): how bricks are kept once
  /// sampled.
  void pack();
  /// Sets the known points and their values (in point order), packed: a copy of another
  /// process's brick, or the corners of a candidate brick.
  void assign(const Bits<kBrickPoints>& known_points, const float* values);
  /// The known values in point order, in either form.
  void known_values(std::vector<float>& out) const;

 private:
  PoolFloats full;                                    // kBrickPoints values, while sampled
  PoolFloats packed;                                  // the known values in point order, otherwise
  std::uint16_t rank[(kBrickPoints + 63) / 64] = {};  // known points before each word

 public:
  std::uint8_t flagged4 = 0;  ///< 4-cells (of 8) flagged at stride 4, before dilation
  std::uint8_t refine4 = 0;   ///< 4-cells refined to stride 2
  std::uint8_t done4 = 0;     ///< 4-cells whose stride-2 points were evaluated and flagged
  bool started = false;       ///< the stride-4 level ran
  bool refined8 = false;      ///< flagged (or dilated) at stride 8: runs the stride-4 level
  std::uint64_t refine2 = 0;  ///< 2-cells (of 64) refined to stride 1
  std::uint64_t done2 = 0;    ///< 2-cells whose stride-1 points were evaluated
  Bits<kBrickCells> surface;  ///< crossing cells: the ones to mesh
  Bits<kBrickCells> visited;  ///< cells the closure has looked at
  /// Requests of neighbours waiting for the brick's next visit: 4-cells to refine, cells to
  /// look at. Neighbours of other classes write them while the brick waits.
  std::atomic<std::uint8_t> inbox4{0};
  std::atomic<std::uint64_t> inbox_cells[kBrickCells / 64] = {};
  std::atomic<bool> scheduled{false};  ///< in a class's list for a visit
  /// The 26 neighbours (index (dx + 1) * 9 + (dy + 1) * 3 + dz + 1), null where none exists.
  Brick* around[27] = {};
};

static_assert(sizeof(Brick) <= kPoolLargest && alignof(Brick) <= 64);

/// The bricks of a sampled grid, sorted by key.
using BrickList = std::vector<std::unique_ptr<Brick>>;

/// Samples the solid into bricks: the coarse-to-fine refinement of docs/design.md, sections 3
/// and 6 (a coarse lattice at stride 16 with cell centres, then strides 8, 4, 2, 1 where the
/// samples change sign or the field varies more than its smallest magnitude, dilated at strides
/// >= 4), and the closure that follows the surface across cell faces, executed brick by brick
/// in parallel.
/// Evaluations go through the batched classifier. The result does not depend on the number of
/// threads: every decision depends only on values, and the closure is a fixed point.
class BrickSampler {
 public:
  BrickSampler(const Solid& solid, const GridGeometry& geo, const SampleOptions& opts);

  /// Runs the sampling; returns the bricks that hold surface cells (and those the refinement
  /// visited), sorted by key.
  BrickList run();

  std::uint64_t evaluations() const { return evaluations_; }
  /// Coarse blocks (16^3) whose samples were all inside: uniform interior (for the VDB tiles).
  const std::vector<std::array<int, 3>>& interior_blocks() const { return interior_; }

 private:
  struct Impl;      // the visits of bricks: their points, levels and closure
  struct Sampling;  // one run: the bricks by key, the coarse lattice, the rounds of visits
  const Solid& solid_;
  GridGeometry geo_;
  SampleOptions opts_;
  std::uint64_t evaluations_ = 0;
  std::vector<std::array<int, 3>> interior_;
};

/// The value of grid point (i, j, k) that is never evaluated: outside the index range (1) or
/// excluded by a clip plane (the constraint in voxels, > 0). False for points that are sampled.
bool virtual_value(const GridGeometry& geo, const Solid& solid, int i, int j, int k, float* v);

}  // namespace qjulia::detail
