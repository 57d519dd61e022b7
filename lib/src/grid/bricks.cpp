#include "grid/bricks.h"

#include <malloc.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <stdexcept>

#include "base/distribution.h"
#include "base/stage_progress.h"
#include "qjulia/base/error.h"

namespace qjulia::detail {
namespace {

// A cell is refined when its sampled values do not change sign but their smallest magnitude is
// below kRoughness times their spread: the field may cross zero between the samples.
constexpr float kRoughness = 1.0f;
// The stride of the coarse lattice.
constexpr int kCoarse = 16;
// Bricks of a class visited together, sharing their batches of evaluations.
constexpr std::size_t kGroup = 32;

int floor_div(int a, int b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }

// The points queued for one call of the field: their coordinates and where each value goes.
// The arrays only grow (room is made before a run of points is queued, then each is written
// in place); `n` points are queued.
struct Batch {
  std::vector<double> x, y, z;
  std::vector<float> out;
  std::vector<float*> dest;
  std::size_t n = 0;
  // Room for `more` points after the queued ones.
  void reserve(std::size_t more) {
    if (n + more <= x.size()) return;
    const std::size_t size = std::max(2 * x.size(), n + more);
    x.resize(size);
    y.resize(size);
    z.resize(size);
    dest.resize(size);
  }
  // Queues a point; reserve() made room for it.
  void put(double px, double py, double pz, float* to) {
    x[n] = px;
    y[n] = py;
    z[n] = pz;
    dest[n] = to;
    ++n;
  }
  void clear() { n = 0; }
};

// Whether a set of samples makes its cell one to refine: the samples differ in sign, or the
// field may reach zero between them. Virtual samples (outside the grid or a clip) count for the
// sign, not for the spread.
struct Flagger {
  int inside = 0, total = 0;
  float lo = std::numeric_limits<float>::max(), hi = -std::numeric_limits<float>::max();
  void add(float v, bool is_virtual) {
    inside += v <= 0;
    ++total;
    if (!is_virtual) {
      lo = std::min(lo, v);
      hi = std::max(hi, v);
    }
  }
  bool refine(bool rough_allowed) const {
    if (inside != 0 && inside != total) return true;
    if (!rough_allowed || !(lo <= hi)) return false;
    const float m = lo > 0 ? lo : -hi;
    return m < kRoughness * (hi - lo);
  }
};

// Requests a brick makes of its neighbours: refine a 4-cell (dilation), look at a cell
// (closure).
struct Request {
  std::uint64_t key;
  std::uint8_t refine4 = 0;
  std::uint16_t cell = 0xffff;  // local cell index, or none
};

// What a visit sends on: requests to bricks that do not exist yet (created after the class),
// and existing bricks whose inbox it filled (to visit).
struct Outbox {
  std::vector<Request> missing;
  std::vector<Brick*> schedule;
  std::vector<Request> remote;  // to bricks another rank owns
};

// The local coordinates of each of a brick's 9^3 points, and the point sets its levels
// evaluate, as bit sets.
struct PointTables {
  std::uint8_t at[kBrickPoints][3];
  Bits<kBrickPoints> face;        // points with a local coordinate 0 or 8: shared with neighbours
  Bits<kBrickPoints> level8;      // the 8 corners
  Bits<kBrickPoints> level4;      // the 27 points at stride 4
  Bits<kBrickPoints> level2[8];   // the 27 points at stride 2 of each 4-cell
  Bits<kBrickPoints> level1[64];  // the 27 points of each 2-cell
  // For the neighbour in direction o (index (dx + 1) * 9 + (dy + 1) * 3 + dz + 1): its points
  // that are also ours, and how far our index of such a point is from its own.
  Bits<kBrickPoints> shared_with[27];
  int offset[27] = {};
  PointTables() {
    for (int o = 0; o < 27; ++o) {
      const int d[3] = {o / 9 - 1, (o / 3) % 3 - 1, o % 3 - 1};
      offset[o] = (d[0] * kSide * kSide + d[1] * kSide + d[2]) * kBrick;
      for (int i = 0; i < kSide; ++i)
        for (int j = 0; j < kSide; ++j)
          for (int k = 0; k < kSide; ++k) {
            const int ours[3] = {i + kBrick * d[0], j + kBrick * d[1], k + kBrick * d[2]};
            bool in = true;
            for (int a = 0; a < 3; ++a) in = in && ours[a] >= 0 && ours[a] <= kBrick;
            if (in && o != 13) shared_with[o].set(point_index(i, j, k));
          }
    }
    for (int i = 0; i < kSide; ++i)
      for (int j = 0; j < kSide; ++j)
        for (int k = 0; k < kSide; ++k) {
          const int p = point_index(i, j, k);
          at[p][0] = static_cast<std::uint8_t>(i);
          at[p][1] = static_cast<std::uint8_t>(j);
          at[p][2] = static_cast<std::uint8_t>(k);
          auto edge = [](int c) { return c == 0 || c == kBrick; };
          if (edge(i) || edge(j) || edge(k)) face.set(p);
          if (i % 8 == 0 && j % 8 == 0 && k % 8 == 0) level8.set(p);
          if (i % 4 == 0 && j % 4 == 0 && k % 4 == 0) level4.set(p);
        }
    for (int q = 0; q < 8; ++q) {
      const int o[3] = {(q & 1) * 4, ((q >> 1) & 1) * 4, (q >> 2) * 4};
      for (int i = 0; i <= 4; i += 2)
        for (int j = 0; j <= 4; j += 2)
          for (int k = 0; k <= 4; k += 2) level2[q].set(point_index(o[0] + i, o[1] + j, o[2] + k));
    }
    for (int t = 0; t < 64; ++t) {
      const int o[3] = {(t / 16) * 2, ((t / 4) % 4) * 2, (t % 4) * 2};
      for (int i = 0; i <= 2; ++i)
        for (int j = 0; j <= 2; ++j)
          for (int k = 0; k <= 2; ++k) level1[t].set(point_index(o[0] + i, o[1] + j, o[2] + k));
    }
  }
};
const PointTables& point_tables() {
  static const PointTables t;
  return t;
}

// The bricks of a sampling by key: open addressing with linear probing in one array (a brick
// is looked up for each of the 26 neighbours of every brick created). Inserted into between
// the classes only; looked up concurrently.
class BrickMap {
 public:
  BrickMap() : slots_(1024) {}
  // The brick of `key`, or null.
  Brick* find(std::uint64_t key) const {
    for (std::size_t h = hash(key);; ++h) {
      const Slot& s = slots_[h & (slots_.size() - 1)];
      if (!s.claimed) return nullptr;
      if (s.key == key) return s.brick.get();
    }
  }
  // The slot of `key` (holding no brick when new).
  std::unique_ptr<Brick>& operator[](std::uint64_t key) {
    if (2 * (count_ + 1) > slots_.size()) grow();
    for (std::size_t h = hash(key);; ++h) {
      Slot& s = slots_[h & (slots_.size() - 1)];
      if (!s.claimed) {
        s.key = key;
        s.claimed = true;
        ++count_;
        return s.brick;
      }
      if (s.key == key) return s.brick;
    }
  }
  std::size_t size() const { return count_; }
  // Room for `n` bricks in all, made at once (operator[] grows the map by doubling).
  void reserve(std::size_t n) {
    std::size_t slots = slots_.size();
    while (2 * n > slots) slots *= 2;
    if (slots != slots_.size()) rehash(slots);
  }
  // Calls f(brick) for every brick, taking it out of the map; the map is empty after.
  template <class F>
  void drain(F&& f) {
    for (Slot& s : slots_)
      if (s.brick) f(std::move(s.brick));
    std::vector<Slot>(1024).swap(slots_);
    count_ = 0;
  }

 private:
  struct Slot {
    std::uint64_t key = 0;
    bool claimed = false;  // taken by operator[] (its brick may come later)
    std::unique_ptr<Brick> brick;
  };
  static std::size_t hash(std::uint64_t key) {
    return static_cast<std::size_t>((key * 0x9E3779B97F4A7C15ull) >> 17);
  }
  void grow() { rehash(slots_.size() * 2); }
  void rehash(std::size_t slots) {
    std::vector<Slot> old(slots);
    old.swap(slots_);
    count_ = 0;
    for (Slot& s : old)
      if (s.claimed) (*this)[s.key] = std::move(s.brick);
  }
  std::vector<Slot> slots_;
  std::size_t count_ = 0;
};

}  // namespace

void Brick::unpack() {
  if (full) return;
  full.make(kBrickPoints);
  if (packed) {
    std::size_t n = 0;
    known.for_each([&](int p) { full[p] = packed[n++]; });
    packed.reset();
  }
}

void Brick::pack() {
  if (!full) return;
  const std::size_t n = known.count();
  packed.make(std::max<std::size_t>(n, 1));
  std::size_t k = 0;
  for (int w = 0; w < (kBrickPoints + 63) / 64; ++w) {
    rank[w] = static_cast<std::uint16_t>(k);
    for_each_bit(known.w[w], 64 * w, [&](int p) { packed[k++] = full[p]; });
  }
  full.reset();
}

void Brick::known_values(std::vector<float>& out) const {
  out.clear();
  if (!full) {
    out.assign(packed.get(), packed.get() + known.count());
    return;
  }
  known.for_each([&](int p) { out.push_back(full[p]); });
}

void Brick::assign(const Bits<kBrickPoints>& known_points, const float* values) {
  full.reset();
  known = known_points;
  const std::size_t n = known.count();
  packed.make(std::max<std::size_t>(n, 1));
  std::copy(values, values + n, packed.get());
  std::size_t k = 0;
  for (int w = 0; w < (kBrickPoints + 63) / 64; ++w) {
    rank[w] = static_cast<std::uint16_t>(k);
    k += static_cast<std::size_t>(popcount64(known.w[w]));
  }
}

bool virtual_value(const GridGeometry& geo, const Solid& solid, int i, int j, int k, float* v) {
  if (i < 0 || j < 0 || k < 0 || i >= geo.points[0] || j >= geo.points[1] || k >= geo.points[2]) {
    *v = 1.0f;
    return true;
  }
  // Every point in the index range is inside the box; only clip planes can exclude it.
  if (!solid.has_clip()) return false;
  const auto excluded = solid.excluded_field(
      geo.origin[0] + i * geo.voxel, geo.origin[1] + j * geo.voxel, geo.origin[2] + k * geo.voxel);
  if (excluded) *v = *excluded;
  return excluded.has_value();
}

struct BrickSampler::Impl {
  const Solid& solid;
  const GridGeometry& geo;
  const SampleOptions& opts;
  const Distribution* dist = nullptr;  // the ranks of a distributed run, or null
  std::atomic<std::uint64_t> evaluations{0};

  Impl(const Solid& s, const GridGeometry& g, const SampleOptions& o) : solid(s), geo(g), opts(o) {}

  void check_cancel() const {
    if (opts.cancel && opts.cancel->requested()) throw Cancelled();
  }

  // Queues point (i, j, k) (global) for evaluation into *dest, or stores its virtual value.
  // Returns true when the value is virtual.
  bool queue(Batch& b, int i, int j, int k, float* dest) const {
    float v;
    if (virtual_value(geo, solid, i, j, k, &v)) {
      *dest = v;
      return true;
    }
    b.reserve(1);
    b.put(geo.origin[0] + i * geo.voxel, geo.origin[1] + j * geo.voxel,
          geo.origin[2] + k * geo.voxel, dest);
    return false;
  }

  void run(Batch& b) {
    const std::size_t n = b.n;
    if (n == 0) return;
    b.out.resize(n);
    solid.field(b.x.data(), b.y.data(), b.z.data(), n, b.out.data());
    for (std::size_t i = 0; i < n; ++i) *b.dest[i] = b.out[i];
    evaluations += n;
    b.clear();
  }

  bool is_virtual(int i, int j, int k) const {
    float v;
    return virtual_value(geo, solid, i, j, k, &v);
  }

  // --- the brick's points --------------------------------------------------------------------

  // The bricks around the one being visited (null where there is none), and the coarse lattice,
  // from which a point another brick or the lattice already has is copied, not evaluated again.
  // Bricks are visited in eight classes by the parity of their coordinates, one class at a
  // time: no two bricks of a class share a point, so what a brick reads of its neighbours does
  // not change while it runs, and which brick evaluates a shared point does not depend on the
  // thread count.
  struct Around {
    Brick* n[27] = {};
  };
  const BrickMap* map = nullptr;  // the bricks, when points are shared between them
  const float* lattice = nullptr;
  const float* centres = nullptr;
  std::function<std::size_t(int, int, int)> lattice_at;
  int lattice_hi[3] = {0, 0, 0};

  Around around(const Brick& br) const {
    Around a;
    if (!map) return a;
    std::copy(std::begin(br.around), std::end(br.around), a.n);
    return a;
  }

  // Where the value of global point g is kept by a neighbour brick or the coarse lattice, if one
  // has it; null otherwise.
  const float* locate(const Brick& br, const Around& a, const int g[3]) const {
    int lo[3], hi[3], faces = 0;
    for (int k = 0; k < 3; ++k) {
      const int b = (k == 0 ? br.at.x : k == 1 ? br.at.y : br.at.z);
      const int local = g[k] - b * kBrick;
      // The neighbours whose 9^3 points hold g: offset -1 when g is on our lower face, +1 when
      // on our upper face.
      lo[k] = local == 0 ? -1 : 0;
      hi[k] = local == kBrick ? 1 : 0;
      faces += lo[k] != hi[k];
    }
    // A point inside the brick is in no neighbour, nor in the lattice (whose points are brick
    // corners).
    if (faces == 0) return nullptr;
    for (int dx = lo[0]; dx <= hi[0]; ++dx)
      for (int dy = lo[1]; dy <= hi[1]; ++dy)
        for (int dz = lo[2]; dz <= hi[2]; ++dz) {
          if (!dx && !dy && !dz) continue;
          const Brick* n = a.n[(dx + 1) * 9 + (dy + 1) * 3 + (dz + 1)];
          if (!n) continue;
          const int p = point_index(g[0] - n->at.x * kBrick, g[1] - n->at.y * kBrick,
                                    g[2] - n->at.z * kBrick);
          if (n->known.test(p)) return n->where(p);
        }
    if (lattice && faces == 3) {
      constexpr int s = kCoarse;
      auto in_lattice = [&](int i, int j, int k) {
        return i >= -1 && j >= -1 && k >= -1 && i <= lattice_hi[0] + 1 && j <= lattice_hi[1] + 1 &&
               k <= lattice_hi[2] + 1;
      };
      if (g[0] % s == 0 && g[1] % s == 0 && g[2] % s == 0 &&
          in_lattice(g[0] / s, g[1] / s, g[2] / s)) {
        return &lattice[lattice_at(g[0] / s, g[1] / s, g[2] / s)];
      }
      if (g[0] % s == s / 2 && g[1] % s == s / 2 && g[2] % s == s / 2) {
        const int i = g[0] / s, j = g[1] / s, k = g[2] / s;
        if (i <= lattice_hi[0] && j <= lattice_hi[1] && k <= lattice_hi[2]) {
          return &centres[lattice_at(i, j, k)];
        }
      }
    }
    return nullptr;
  }

  // The value of global point g from a neighbour brick or the coarse lattice, if one has it.
  bool lookup(const Brick& br, const Around& a, const int g[3], float* v) const {
    const float* at = locate(br, a, g);
    if (at) *v = *at;
    return at != nullptr;
  }

  // Makes the listed local points of `brick` known: copied from a neighbour or the lattice, or
  // queued in the batch for evaluation.
  template <class F>
  void need(Brick& br, const Around& a, Batch& b, F&& each_point) const {
    each_point([&](int li, int lj, int lk) {
      const int p = point_index(li, lj, lk);
      if (br.known.test(p)) return;
      br.known.set(p);
      const int g[3] = {br.at.x * kBrick + li, br.at.y * kBrick + lj, br.at.z * kBrick + lk};
      if (map && g[0] >= 0 && g[1] >= 0 && g[2] >= 0 && lookup(br, a, g, br.slot(p))) return;
      queue(b, g[0], g[1], g[2], br.slot(p));
    });
  }

  // True when no point of the brick has a virtual value: all inside the index range, no clip.
  bool all_real(const Brick& br) const {
    const int base[3] = {br.at.x * kBrick, br.at.y * kBrick, br.at.z * kBrick};
    for (int k = 0; k < 3; ++k)
      if (base[k] < 0 || base[k] + kBrick > geo.points[k] - 1) return false;
    return !solid.has_clip();
  }

  // Makes the points of `want` known (the brick unpacked): copied from a neighbour or the
  // lattice, or queued in the batch for evaluation; `real` when no point of the brick is virtual.
  // `avail`, when given, holds the points some neighbour knows (neighbours_know()).
  void need_mask(Brick& br, const Around& a, Bits<kBrickPoints> want, Batch& b, bool real,
                 const Bits<kBrickPoints>* avail = nullptr) const {
    using Pts = Bits<kBrickPoints>;
    const PointTables& t = point_tables();
    want = want & ~br.known;
    br.known = br.known | want;
    const int base[3] = {br.at.x * kBrick, br.at.y * kBrick, br.at.z * kBrick};
    if (map) {
      // Only points on the brick's faces can be held by a neighbour or the lattice (whose
      // points are brick corners).
      const Pts shared = avail ? want & (*avail | (t.level8 & t.face)) : want & t.face;
      // First where each value is (its cache line fetched meanwhile: the neighbours' values are
      // scattered over the heap), then the values.
      thread_local std::vector<std::pair<int, const float*>> found;
      found.clear();
      shared.for_each([&](int p) {
        const int g[3] = {base[0] + t.at[p][0], base[1] + t.at[p][1], base[2] + t.at[p][2]};
        if (g[0] < 0 || g[1] < 0 || g[2] < 0) return;
        if (const float* at = locate(br, a, g)) {
          __builtin_prefetch(at);
          found.emplace_back(p, at);
        }
      });
      for (const auto& [p, at] : found) {
        *br.slot(p) = *at;
        want.w[p >> 6] &= ~(std::uint64_t{1} << (p & 63));
      }
    }
    b.reserve(want.count());
    want.for_each([&](int p) {
      const int g[3] = {base[0] + t.at[p][0], base[1] + t.at[p][1], base[2] + t.at[p][2]};
      if (!real && virtual_value(geo, solid, g[0], g[1], g[2], br.slot(p))) return;
      // From the global index, as every other path computes a grid point.
      b.put(geo.origin[0] + g[0] * geo.voxel, geo.origin[1] + g[1] * geo.voxel,
            geo.origin[2] + g[2] * geo.voxel, br.slot(p));
    });
  }

  // The known-point sets of the 26 bricks around one (index as Brick::around) are scattered
  // over the heap: their cache lines, and those where() reads to find a value, are all asked for
  // before any is read (the latter made sampling 4% faster, classic-julia 512).
  static void prefetch_known(Brick* const* around) {
    for (int o = 0; o < 27; ++o)
      if (o != 13 && around[o]) {
        const char* known = reinterpret_cast<const char*>(&around[o]->known);
        __builtin_prefetch(known);
        __builtin_prefetch(known + sizeof(Bits<kBrickPoints>) - 1);
        around[o]->prefetch_where();
      }
  }

  // The points of the brick that one of its neighbours knows: their known points on the
  // faces they share with it, in its numbering.
  Bits<kBrickPoints> neighbours_know(const Around& a) const {
    const PointTables& t = point_tables();
    Bits<kBrickPoints> avail;
    if (!map) return avail;
    prefetch_known(a.n);
    for (int o = 0; o < 27; ++o)
      if (o != 13 && a.n[o])
        avail = avail | shifted(a.n[o]->known & t.shared_with[o], -t.offset[o]);
    return avail;
  }

  // Flags the cube of side s (points) at local lower corner (i, j, k) by its corners (and its
  // centre when `centre`); `real` when no point of the brick is virtual.
  bool flag_cube(const Brick& br, int i, int j, int k, int s, bool centre,
                 bool real = false) const {
    Flagger f;
    if (real && !centre) {
      for (int d = 0; d < 8; ++d)
        f.add(br.get(point_index(i + (d & 1) * s, j + ((d >> 1) & 1) * s, k + (d >> 2) * s)),
              false);
      return f.refine(s > 1);
    }
    for (int d = 0; d < 8; ++d) {
      const int a = i + (d & 1) * s, bb = j + ((d >> 1) & 1) * s, c = k + (d >> 2) * s;
      f.add(br.get(point_index(a, bb, c)),
            is_virtual(br.at.x * kBrick + a, br.at.y * kBrick + bb, br.at.z * kBrick + c));
    }
    if (centre) {
      const int a = i + s / 2, bb = j + s / 2, c = k + s / 2;
      f.add(br.get(point_index(a, bb, c)),
            is_virtual(br.at.x * kBrick + a, br.at.y * kBrick + bb, br.at.z * kBrick + c));
    }
    return f.refine(s > 1);
  }

  // --- one visit of a brick -------------------------------------------------------------------

  // Level 8 of candidate bricks: their corners; hit[i] true when brick i is to be refined.
  // The bricks of a group share one batch of evaluations; a candidate keeps only its corners,
  // packed (most are never refined).
  void flag8(Brick* const* group, std::size_t n, Batch& b, char* hit) {
    thread_local std::vector<std::array<float, 8>> values;
    if (values.size() < n) values.resize(n);
    // The corners are looked for in the neighbours' known-point sets.
    for (std::size_t i = 0; i < n; ++i) prefetch_known(group[i]->around);
    for (std::size_t i = 0; i < n; ++i) {
      Brick& br = *group[i];
      const Around a = around(br);
      for (int d = 0; d < 8; ++d) {
        const int l[3] = {(d & 1) * kBrick, ((d >> 1) & 1) * kBrick, (d >> 2) * kBrick};
        const int p = point_index(l[0], l[1], l[2]);
        float* dest = &values[i][d];
        if (br.known.test(p)) {
          *dest = br.get(p);
          continue;
        }
        const int g[3] = {br.at.x * kBrick + l[0], br.at.y * kBrick + l[1],
                          br.at.z * kBrick + l[2]};
        if (map && g[0] >= 0 && g[1] >= 0 && g[2] >= 0 && lookup(br, a, g, dest)) continue;
        queue(b, g[0], g[1], g[2], dest);
      }
    }
    run(b);
    for (std::size_t i = 0; i < n; ++i) {
      Brick& br = *group[i];
      Flagger f;
      Bits<kBrickPoints> corners;
      float sorted[8];
      for (int d = 0; d < 8; ++d) {
        const int l[3] = {(d & 1) * kBrick, ((d >> 1) & 1) * kBrick, (d >> 2) * kBrick};
        f.add(values[i][d], is_virtual(br.at.x * kBrick + l[0], br.at.y * kBrick + l[1],
                                       br.at.z * kBrick + l[2]));
        corners.set(point_index(l[0], l[1], l[2]));
        // Point order: k fastest, then j, then i.
        sorted[((d & 1) << 2) | (d & 2) | (d >> 2)] = values[i][d];
      }
      hit[i] = f.refine(true);
      br.assign(corners, sorted);
    }
  }

  // Runs the refinement of a brick from its requests; appends requests to its neighbours.
  // Puts a request in the inbox of the neighbour, or in `out` when that brick does not exist.
  void deliver(const Around& a, const Brick& br, const Request& r, Outbox& out) const {
    const BrickCoord to = brick_of_key(r.key);
    if (dist && !dist->owns(to.x)) {
      out.remote.push_back(r);
      return;
    }
    Brick* n = a.n[(to.x - br.at.x + 1) * 9 + (to.y - br.at.y + 1) * 3 + (to.z - br.at.z + 1)];
    if (!n) {
      out.missing.push_back(r);
      return;
    }
    deposit(*n, r, out);
  }
  // A bit already in the inbox is not set again: the inbox is only emptied by the brick's own
  // visit, in another class, so a plain load sees it, and the atomic write (a locked bus
  // operation on a neighbour's cache line) is saved.
  static void deposit(Brick& n, const Request& r, Outbox& out) {
    bool fresh = false;
    const std::uint8_t want4 = r.refine4 & static_cast<std::uint8_t>(~n.refine4);
    if (want4 && (n.inbox4.load(std::memory_order_relaxed) & want4) != want4)
      fresh = (n.inbox4.fetch_or(want4) & want4) != want4;
    if (r.cell != 0xffff && !n.visited.test(r.cell)) {
      const std::uint64_t bit = std::uint64_t{1} << (r.cell & 63);
      std::atomic<std::uint64_t>& box = n.inbox_cells[r.cell >> 6];
      if (!(box.load(std::memory_order_relaxed) & bit)) fresh = !(box.fetch_or(bit) & bit) || fresh;
    }
    if (fresh && !n.scheduled.exchange(true)) out.schedule.push_back(&n);
  }

  using Pts = Bits<kBrickPoints>;
  // One brick's visit in progress: what its levels and its closure need between the batches
  // of evaluations that the bricks of a group share.
  struct Visit {
    Brick* br = nullptr;
    Around a;
    std::uint8_t seed4 = 0, new4 = 0;
    std::uint64_t new2 = 0;
    bool level4 = false;
    std::vector<std::uint16_t> frontier_cells;
    // The closure, over the 9^3 points (a cell named by its lower corner).
    Pts valid, frontier, visited, surface, sign;
    std::vector<int> queued;
    bool closing = false;
    bool real = false;         // no point of the brick is virtual
    Bits<kBrickPoints> avail;  // the points a neighbour knows
  };

  // Visits a group of bricks of one class: each level (4, 2, 1) and each round of the closure
  // evaluates the points of all the group's bricks in one batch. Bricks of a class share no
  // point, so the group's bricks do exactly what they would do one at a time.
  void visit(Brick* const* group, std::size_t n, Batch& b, Outbox& out) {
    thread_local std::vector<Visit> visits;
    if (visits.size() < n) visits.resize(n);
    for (std::size_t i = 0; i < n; ++i) begin_visit(visits[i], *group[i], b);
    run(b);
    for (std::size_t i = 0; i < n; ++i) {
      Visit& v = visits[i];
      Brick& br = *v.br;
      // Flagged 4-cells dilated by one 4-cell.
      if (v.level4) level4_flags(v, out);
      br.started = true;
      br.refine4 |= v.seed4;
      // Level 2: the 27 points at stride 2 of each new 4-cell.
      v.new4 = br.refine4 & static_cast<std::uint8_t>(~br.done4);
      if (v.new4) {
        Pts want;
        for (int q = 0; q < 8; ++q)
          if (v.new4 >> q & 1) want = want | point_tables().level2[q];
        need_mask(br, v.a, want, b, v.real, &v.avail);
      }
    }
    run(b);
    for (std::size_t i = 0; i < n; ++i) {
      Visit& v = visits[i];
      Brick& br = *v.br;
      // Its 2-cells flagged.
      if (v.new4) level2_flags(v);
      // Level 1: the points of each new 2-cell.
      v.new2 = br.refine2 & ~br.done2;
      if (v.new2) {
        Pts want;
        for_each_bit(v.new2, 0, [&](int c) { want = want | point_tables().level1[c]; });
        need_mask(br, v.a, want, b, v.real, &v.avail);
      }
    }
    run(b);
    for (std::size_t i = 0; i < n; ++i) {
      Visit& v = visits[i];
      // Its crossing voxels start the closure.
      if (v.new2) {
        for_each_bit(v.new2, 0, [&](int t) {
          const int o[3] = {(t / 16) * 2, ((t / 4) % 4) * 2, (t % 4) * 2};
          for (int r = 0; r < 8; ++r)
            v.frontier_cells.push_back(static_cast<std::uint16_t>(
                cell_index(o[0] + (r & 1), o[1] + ((r >> 1) & 1), o[2] + (r >> 2))));
        });
        v.br->done2 |= v.new2;
      }
      close_start(v);
    }
    for (;;) {
      bool any = false;
      for (std::size_t i = 0; i < n; ++i)
        if (visits[i].closing) any = close_need(visits[i], b) || any;
      if (!any) break;
      run(b);
      for (std::size_t i = 0; i < n; ++i)
        if (visits[i].closing) close_step(visits[i], out);
    }
    for (std::size_t i = 0; i < n; ++i) {
      close_finish(visits[i]);
      visits[i].br->pack();
    }
  }

  // The start of a brick's visit: what its neighbours asked for since the last visit, and its
  // points of level 4 queued when it runs that level.
  void begin_visit(Visit& v, Brick& br, Batch& b) const {
    v.br = &br;
    v.a = around(br);
    br.unpack();
    // What the neighbours asked for since the last visit.
    // (An empty inbox word is only read: an exchange is a locked operation.)
    auto take = [](auto& box) { return box.load(std::memory_order_relaxed) ? box.exchange(0) : 0; };
    v.seed4 = take(br.inbox4);
    v.frontier_cells.clear();
    for (int w = 0; w < kBrickCells / 64; ++w)
      for_each_bit(take(br.inbox_cells[w]), 64 * w,
                   [&](int c) { v.frontier_cells.push_back(static_cast<std::uint16_t>(c)); });
    v.real = all_real(br);
    v.avail = neighbours_know(v.a);
    // Level 4: the 27 points at stride 4.
    v.level4 = br.refined8 && !br.started;
    if (v.level4) need_mask(br, v.a, point_tables().level4, b, v.real, &v.avail);
  }

  // The 2-cells of the brick's new 4-cells whose samples call for refinement.
  void level2_flags(Visit& v) const {
    Brick& br = *v.br;
    for (int q = 0; q < 8; ++q) {
      if (!(v.new4 >> q & 1)) continue;
      const int o[3] = {(q & 1) * 4, ((q >> 1) & 1) * 4, (q >> 2) * 4};
      for (int r = 0; r < 8; ++r) {
        const int c[3] = {o[0] + (r & 1) * 2, o[1] + ((r >> 1) & 1) * 2, o[2] + (r >> 2) * 2};
        if (flag_cube(br, c[0], c[1], c[2], 2, false, v.real))
          br.refine2 |= std::uint64_t{1} << ((c[0] / 2) * 16 + (c[1] / 2) * 4 + c[2] / 2);
      }
    }
    br.done4 |= v.new4;
  }

  // The 4-cells of level 4 whose samples call for refinement, dilated by one 4-cell: in this
  // brick (seed4) or by requests to its neighbours.
  void level4_flags(Visit& v, Outbox& out) {
    Brick& br = *v.br;
    for (int q = 0; q < 8; ++q)
      if (flag_cube(br, (q & 1) * 4, ((q >> 1) & 1) * 4, (q >> 2) * 4, 4, false, v.real))
        br.flagged4 |= static_cast<std::uint8_t>(1u << q);
    // The 4-cells asked of each neighbour (by its offset), one request per neighbour.
    std::uint8_t ask[27] = {};
    for (int q = 0; q < 8; ++q) {
      if (!(br.flagged4 >> q & 1)) continue;
      const int c[3] = {q & 1, (q >> 1) & 1, q >> 2};
      for (int dx = -1; dx <= 1; ++dx)
        for (int dy = -1; dy <= 1; ++dy)
          for (int dz = -1; dz <= 1; ++dz) {
            const int n[3] = {c[0] + dx, c[1] + dy, c[2] + dz};
            const int bo[3] = {floor_div(n[0], 2), floor_div(n[1], 2), floor_div(n[2], 2)};
            const int lq =
                (n[0] - 2 * bo[0]) | ((n[1] - 2 * bo[1]) << 1) | ((n[2] - 2 * bo[2]) << 2);
            ask[(bo[0] + 1) * 9 + (bo[1] + 1) * 3 + bo[2] + 1] |=
                static_cast<std::uint8_t>(1u << lq);
          }
    }
    v.seed4 |= ask[13];
    for (int o = 0; o < 27; ++o) {
      if (o == 13 || !ask[o]) continue;
      const int nb[3] = {br.at.x + o / 9 - 1, br.at.y + (o / 3) % 3 - 1, br.at.z + o % 3 - 1};
      if (in_range(nb)) deliver(v.a, br, {brick_key(nb[0], nb[1], nb[2]), ask[o]}, out);
    }
  }

  bool in_range(const int nb[3]) const {
    for (int a = 0; a < 3; ++a)
      if (nb[a] < -1 || nb[a] * kBrick > geo.points[a] - 1) return false;
    return true;
  }

  // The closure: a crossing cell whose face has a sign change continues into the cell across
  // that face, which is then examined too (in this brick, or by a request to the neighbour).
  // Done with bit sets over the 9^3 points (a cell is named by its lower corner), a whole
  // frontier at a time: close_need() asks for the corners of the frontier's cells,
  // close_step() takes the next frontier from their signs, until none is left.
  static constexpr int kStride[3] = {81, 9, 1};
  static constexpr int kCorner[8] = {0, 81, 9, 90, 1, 82, 10, 91};

  void close_start(Visit& v) const {
    const Brick& br = *v.br;
    const int base[3] = {br.at.x * kBrick, br.at.y * kBrick, br.at.z * kBrick};
    // Cells that exist: local 0..7, globally -1 .. points - 1.
    int lo[3], hi[3];
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::max(0, -1 - base[k]);
      hi[k] = std::min(kBrick - 1, geo.points[k] - 1 - base[k]);
    }
    // The cells of a brick inside the grid, named by their lower corners (all 8^3 of them).
    static const Pts kAllCells = [] {
      Pts all;
      for (int i = 0; i < kBrick; ++i)
        for (int j = 0; j < kBrick; ++j)
          for (int k = 0; k < kBrick; ++k) all.set(point_index(i, j, k));
      return all;
    }();
    v.valid = v.frontier = v.visited = v.surface = v.sign = Pts();
    if (lo[0] == 0 && lo[1] == 0 && lo[2] == 0 && hi[0] == kBrick - 1 && hi[1] == kBrick - 1 &&
        hi[2] == kBrick - 1) {
      v.valid = kAllCells;
    } else {
      for (int i = lo[0]; i <= hi[0]; ++i)
        for (int j = lo[1]; j <= hi[1]; ++j)
          for (int k = lo[2]; k <= hi[2]; ++k) v.valid.set(point_index(i, j, k));
    }
    auto to_point = [](int c) { return point_index(c / 64, (c / 8) % 8, c % 8); };
    br.visited.for_each([&](int c) { v.visited.set(to_point(c)); });
    br.surface.for_each([&](int c) { v.surface.set(to_point(c)); });
    for (std::uint16_t c : v.frontier_cells) v.frontier.set(to_point(c));
    // (Without a branch on the sign, which follows no pattern near the surface.)
    br.known.for_each(
        [&](int p) { v.sign.w[p >> 6] |= std::uint64_t{br.get(p) <= 0} << (p & 63); });
    v.closing = true;
  }

  // The corners of the frontier's cells that are not known yet, queued; false when the closure
  // of the brick is complete.
  bool close_need(Visit& v, Batch& b) const {
    Brick& br = *v.br;
    v.frontier = v.frontier & v.valid & ~v.visited;
    if (!v.frontier.any()) {
      v.closing = false;
      return false;
    }
    v.visited = v.visited | v.frontier;
    Pts corners;
    for (int d = 0; d < 8; ++d) corners = corners | shifted(v.frontier, -kCorner[d]);
    corners = corners & ~br.known;
    v.queued.clear();
    corners.for_each([&](int p) { v.queued.push_back(p); });
    need_mask(br, v.a, corners, b, v.real, &v.avail);
    return true;
  }

  // With the frontier's corners known: its crossing cells, and across their faces with a sign
  // change the next frontier, or requests to the neighbours.
  void close_step(Visit& v, Outbox& out) const {
    const Brick& br = *v.br;
    const int base[3] = {br.at.x * kBrick, br.at.y * kBrick, br.at.z * kBrick};
    for (int p : v.queued) v.sign.w[p >> 6] |= std::uint64_t{br.get(p) <= 0} << (p & 63);
    // Crossing cells: corners of both signs.
    Pts any_in, all_in = v.frontier;
    Pts corner_sign[8];
    for (int d = 0; d < 8; ++d) {
      corner_sign[d] = shifted(v.sign, kCorner[d]);
      any_in = any_in | corner_sign[d];
      all_in = all_in & corner_sign[d];
    }
    const Pts crossing = v.frontier & any_in & ~all_in;
    v.surface = v.surface | crossing;
    Pts next;
    for (int axis = 0; axis < 3; ++axis)
      for (int t = 0; t < 2; ++t) {
        Pts f_any, f_all = crossing;
        for (int d = 0; d < 8; ++d) {
          if (((d >> axis) & 1) != t) continue;
          f_any = f_any | corner_sign[d];
          f_all = f_all & corner_sign[d];
        }
        const Pts go = crossing & f_any & ~f_all;
        if (!go.any()) continue;
        next = next | shifted(go, t ? -kStride[axis] : kStride[axis]);
        // Cells on the brick's face go to the neighbour.
        go.for_each([&](int p) {
          const auto& at = point_tables().at[p];
          int n[3] = {at[0], at[1], at[2]};
          if (n[axis] != (t ? kBrick - 1 : 0)) return;
          const int gn = base[axis] + n[axis] + (t ? 1 : -1);
          if (gn < -1 || gn >= geo.points[axis]) return;
          int nb[3] = {br.at.x, br.at.y, br.at.z};
          nb[axis] += t ? 1 : -1;
          n[axis] = t ? 0 : kBrick - 1;
          const std::uint16_t nc = static_cast<std::uint16_t>(cell_index(n[0], n[1], n[2]));
          // A neighbour that has looked at the cell needs no request.
          const Brick* known =
              v.a.n[(nb[0] - br.at.x + 1) * 9 + (nb[1] - br.at.y + 1) * 3 + (nb[2] - br.at.z + 1)];
          if (known && known->visited.test(nc)) return;
          Request r{brick_key(nb[0], nb[1], nb[2])};
          r.cell = nc;
          deliver(v.a, br, r, out);
        });
      }
    v.frontier = next;
  }

  // Back to cell numbering.
  static void close_finish(Visit& v) {
    Brick& br = *v.br;
    const PointTables& t = point_tables();
    auto cell = [&](int p) { return cell_index(t.at[p][0], t.at[p][1], t.at[p][2]); };
    v.visited.for_each([&](int p) { br.visited.set(cell(p)); });
    v.surface.for_each([&](int p) { br.surface.set(cell(p)); });
  }
};

BrickSampler::BrickSampler(const Solid& solid, const GridGeometry& geo, const SampleOptions& opts)
    : solid_(solid), geo_(geo), opts_(opts) {}

namespace {

// The ranks' slabs: contiguous ranges of brick planes (x) of about equal weight.
std::vector<int> deal_planes(const std::vector<double>& weight, int lowest, int ranks) {
  double total = 0;
  for (double w : weight) total += w;
  std::vector<int> first(ranks + 1);
  first[0] = lowest;
  const int planes = static_cast<int>(weight.size());
  double acc = 0;
  int p = 0;
  for (int r = 1; r < ranks; ++r) {
    const double goal = total * r / ranks;
    while (p < planes && acc + 0.5 * weight[p] < goal) acc += weight[p++];
    first[r] = lowest + p;
  }
  first[ranks] = lowest + planes;
  return first;
}

// After sampling, the slabs are dealt again by what meshing them costs, now known exactly: the
// surface cells of each plane of bricks (the vertices, the refinement and the plans follow
// them). The bricks move to their new owners with their known values and cells; the slabs stay
// contiguous in key order, so the ranks' bricks in rank order are still one process's.
void redeal_for_meshing(BrickList& mine, Distribution& dist, int lowest_plane) {
  Comm& comm = *dist.comm;
  const std::size_t planes = static_cast<std::size_t>(dist.first.back() - lowest_plane);
  std::vector<double> weight(planes, 0.0);
  for (const auto& b : mine)
    weight[static_cast<std::size_t>(b->at.x - lowest_plane)] +=
        static_cast<double>(b->surface.count());
  Packer own;
  own.put_vector(weight);
  std::vector<double> total(planes, 1.0);
  for (const std::string& s : comm.allgather(own.data)) {
    const auto w = Unpacker(s).get_vector<double>();
    for (std::size_t i = 0; i < planes && i < w.size(); ++i) total[i] += w[i];
  }
  Distribution next = dist;
  next.first = deal_planes(total, lowest_plane, comm.size());
  std::vector<Packer> out(comm.size());
  BrickList keep;
  for (auto& b : mine) {
    const int owner = next.rank_of(b->at.x);
    if (owner == comm.rank()) {
      keep.push_back(std::move(b));
      continue;
    }
    Packer& p = out[owner];
    p.put(b->key);
    p.put(b->known);
    p.put(b->surface);
    p.put(b->visited);
    std::vector<float> values;
    values.reserve(b->known.count());
    for (int q = 0; q < kBrickPoints; ++q)
      if (b->known.test(q)) values.push_back(b->get(q));
    p.put_vector(values);
    b.reset();
  }
  std::vector<std::string> to(comm.size());
  for (int r = 0; r < comm.size(); ++r) to[r] = std::move(out[r].data);
  for (const std::string& bytes : comm.exchange(to)) {
    Unpacker u(bytes);
    while (!u.done()) {
      auto b = std::make_unique<Brick>();
      b->key = u.get<std::uint64_t>();
      b->at = brick_of_key(b->key);
      const auto known = u.get<Bits<kBrickPoints>>();
      b->surface = u.get<Bits<kBrickCells>>();
      b->visited = u.get<Bits<kBrickCells>>();
      const auto values = u.get_vector<float>();
      if (values.size() != known.count()) throw std::runtime_error("comm: a brick's values");
      b->assign(known, values.data());
      keep.push_back(std::move(b));
    }
  }
  mine = std::move(keep);
  dist.first = std::move(next.first);
}

}  // namespace

// One run of the sampler: the bricks by key (created and linked with their neighbours as they
// are asked for), the coarse lattice of the sparse path, and the steps from the lattice to the
// closure. BrickSampler::run() takes the dense path or the sparse one, then lists the bricks.
struct BrickSampler::Sampling {
  Impl im;
  const GridGeometry& geo;
  const SampleOptions& opts;
  Distribution* const dist;  // the ranks of a distributed run, or null
  const int rank, ranks;
  // Brick planes: x from -1 to the last that holds a grid point.
  const int lowest_plane = -1, highest_plane;
  std::vector<std::array<int, 3>>& interior;  // the sampler's interior blocks
  BrickMap bricks;
  RisingProgress progress;  // reported from the steps of run() and from parallel work
  // The coarse lattice (the sparse path): its points and the centres of its cells, by
  // lattice_index(); points -1 .. hi + 1 per axis, centres -1 .. hi.
  int hi[3] = {0, 0, 0};
  int n1 = 0, n2 = 0;
  std::vector<float> lattice, centre;
  // The rounds of visits (the sparse path): the bricks waiting for a visit, by class.
  std::vector<Brick*> pending[8];
  std::size_t visits = 0, first_round = 0;

  Sampling(const Solid& solid, const GridGeometry& geo, const SampleOptions& opts,
           std::vector<std::array<int, 3>>& interior)
      : im(solid, geo, opts),
        geo(geo),
        opts(opts),
        dist(opts.distribution && opts.distribution->comm ? opts.distribution : nullptr),
        rank(dist ? dist->comm->rank() : 0),
        ranks(dist ? dist->comm->size() : 1),
        highest_plane((geo.points[0] - 1) / kBrick),
        interior(interior),
        progress(opts.progress, opts.cancel) {
    // The dense path evaluates every point of every brick itself (the reference the sparse path
    // is tested against); the sparse path shares points between neighbours.
    if (!dense_path()) im.map = &bricks;
    im.dist = dist;
  }

  // A grid of at most two coarse blocks a side is sampled densely: the coarse lattice would hold
  // too few points to see the surface.
  bool dense_path() const {
    const auto& P = geo.points;
    return opts.dense || std::max({P[0], P[1], P[2]}) <= 2 * kCoarse;
  }

  // Throws Cancelled when asked to stop; reports progress f (from any thread).
  void report(double f) { progress.report(std::min(1.0, f)); }

  // A brick by key, created when new and linked with its neighbours both ways.
  Brick& get(std::uint64_t key) {
    auto& slot = bricks[key];
    if (!slot) {
      slot = std::make_unique<Brick>();
      Brick& b = *slot;
      b.key = key;
      b.at = brick_of_key(key);
      for (int o = 0; o < 27; ++o) {
        if (o == 13) continue;
        const int dx = o / 9 - 1, dy = (o / 3) % 3 - 1, dz = o % 3 - 1;
        Brick* n = bricks.find(brick_key(b.at.x + dx, b.at.y + dy, b.at.z + dz));
        if (!n) continue;
        b.around[o] = n;
        n->around[26 - o] = &b;
      }
    }
    return *slot;
  }

  // The bricks of `keys` (sorted, unique) that do not exist yet, created and linked with their
  // neighbours as get() does, in parallel: at 512^3 the level-8 candidates are some 90,000
  // bricks, and their 26 lookups each (cache misses in a map of megabytes) took 0.4 s on one
  // thread.
  void create(const std::vector<std::uint64_t>& keys) {
    const std::size_t before = bricks.size();
    std::vector<std::unique_ptr<Brick>> fresh(keys.size());
    tbb::parallel_for(std::size_t{0}, keys.size(), [&](std::size_t i) {
      if (bricks.find(keys[i])) return;
      fresh[i] = std::make_unique<Brick>();
      fresh[i]->key = keys[i];
      fresh[i]->at = brick_of_key(keys[i]);
    });
    std::vector<Brick*> made;
    made.reserve(keys.size());
    for (auto& b : fresh)
      if (b) made.push_back(b.get());
    // Room for the new bricks only (most keys after the first creation exist already: room for
    // all of them doubled the map at 512, 7 ms of rehashing on one thread).
    bricks.reserve(before + made.size());
    for (auto& b : fresh)
      if (b) bricks[b->key] = std::move(b);
    if (!std::is_sorted(made.begin(), made.end(),
                        [](const Brick* a, const Brick* b) { return a->key < b->key; }))
      throw std::logic_error("sampler: bricks to create out of key order");
    if (before == 0) {
      // All bricks are new, in key order: each finds its upper 13 neighbours and links both
      // ways (a slot is written by one brick only: the neighbour at its offset). The neighbour
      // at an upper offset has the brick's key plus the offset's (positive) key difference, so
      // the bricks and their neighbours at one offset are two sorted lists, walked together.
      tbb::parallel_for(14, 27, [&](int o) {
        const int d[3] = {o / 9 - 1, (o / 3) % 3 - 1, o % 3 - 1};
        std::size_t j = 0;
        for (Brick* b : made) {
          // A coordinate below -1 is no brick's (and would borrow from the next field).
          if (b->at.x + d[0] < -1 || b->at.y + d[1] < -1 || b->at.z + d[2] < -1) continue;
          const std::uint64_t want = neighbour_key(*b, o);
          while (j < made.size() && made[j]->key < want) ++j;
          if (j == made.size()) break;
          if (made[j]->key == want) {
            b->around[o] = made[j];
            made[j]->around[26 - o] = b;
          }
        }
      });
      return;
    }
    // Each new brick links its own neighbours; bricks that existed before link back to it.
    tbb::parallel_for(std::size_t{0}, made.size(), [&](std::size_t i) {
      Brick& b = *made[i];
      for (int o = 0; o < 27; ++o)
        if (o != 13) b.around[o] = bricks.find(neighbour_key(b, o));
    });
    // Slots of older bricks that point to new ones: each is one new brick's (its offset).
    std::vector<std::uint64_t> made_keys(made.size());
    for (std::size_t i = 0; i < made.size(); ++i) made_keys[i] = made[i]->key;  // in key order
    tbb::parallel_for(std::size_t{0}, made.size(), [&](std::size_t i) {
      Brick* b = made[i];
      for (int o = 0; o < 27; ++o) {
        Brick* n = b->around[o];
        if (o != 13 && n && !std::binary_search(made_keys.begin(), made_keys.end(), n->key))
          n->around[26 - o] = b;
      }
    });
  }

  static std::uint64_t neighbour_key(const Brick& b, int o) {
    return brick_key(b.at.x + o / 9 - 1, b.at.y + (o / 3) % 3 - 1, b.at.z + o % 3 - 1);
  }

  // This rank's bricks, and the planes of the neighbouring ranks' next to them (their copies,
  // for the values and cells this rank's bricks read).
  bool owned(int bx) const { return !dist || dist->owns(bx); }
  bool kept(int bx) const {
    return !dist || (bx >= dist->first[rank] - 1 && bx <= dist->first[rank + 1]);
  }

  // After each class of a distributed run: the requests to other ranks' bricks go to their
  // owners (which create the bricks asked for and schedule them), and the bricks next to another
  // rank that this class changed are copied there.
  void sync(const std::vector<Brick*>& changed, std::vector<Request>& remote, Outbox& arrived) {
    if (!dist) return;
    Comm& comm = *dist->comm;
    std::vector<Packer> to(ranks);
    for (const Request& r : remote) {
      Packer& p = to[dist->rank_of(brick_of_key(r.key).x)];
      p.put(std::uint8_t{0});
      p.put(r);
    }
    for (const Brick* b : changed) {
      for (int side = 0; side < 2; ++side) {
        const int edge_plane = side ? dist->first[rank + 1] - 1 : dist->first[rank];
        const int peer = side ? rank + 1 : rank - 1;
        if (b->at.x != edge_plane || peer < 0 || peer >= ranks) continue;
        Packer& p = to[peer];
        p.put(std::uint8_t{1});
        p.put(b->key);
        p.put(b->known);
        p.put(b->visited);
        std::vector<float> values;
        b->known_values(values);
        p.put_bytes(values.data(), values.size() * sizeof(float));
      }
    }
    std::vector<std::string> out(ranks);
    for (int r = 0; r < ranks; ++r) out[r] = std::move(to[r].data);
    const std::vector<std::string> in = comm.exchange(out);
    std::vector<Request> requests;
    for (const std::string& message : in) {
      Unpacker u(message);
      while (!u.done()) {
        if (u.get<std::uint8_t>() == 0) {
          requests.push_back(u.get<Request>());
        } else {
          Brick& g = get(u.get<std::uint64_t>());
          const auto known = u.get<Bits<kBrickPoints>>();
          g.visited = u.get<Bits<kBrickCells>>();
          std::vector<float> values(known.count());
          u.get_bytes(values.data(), values.size() * sizeof(float));
          g.assign(known, values.data());
        }
      }
    }
    std::sort(requests.begin(), requests.end(),
              [](const Request& a, const Request& b) { return a.key < b.key; });
    for (const Request& r : requests) Impl::deposit(get(r.key), r, arrived);
    remote.clear();
  }

  // Runs f(items + i, count, batch) for the groups of kGroup of items[0, n), in parallel, with
  // a batch per thread.
  template <class T, class F>
  void in_groups(T* items, std::size_t n, F&& f) {
    tbb::parallel_for(
        tbb::blocked_range<std::size_t>(0, n, kGroup),
        [&](const tbb::blocked_range<std::size_t>& r) {
          im.check_cancel();
          thread_local Batch b;
          for (std::size_t i = r.begin(); i < r.end(); i += kGroup)
            f(items + i, std::min(kGroup, r.end() - i), b);
        },
        tbb::simple_partitioner());
  }

  // Runs f(indices, count, batch) for groups of the bricks of `keys`, in eight classes by
  // coordinate parity (see Impl::need), each class in parallel; a distributed run copies the
  // changed bricks to the neighbouring ranks after each class.
  template <class F>
  void by_class(const std::vector<std::uint64_t>& keys, F&& f) {
    std::vector<std::size_t> cls[8];
    for (std::size_t n = 0; n < keys.size(); ++n) {
      const BrickCoord c = brick_of_key(keys[n]);
      cls[(c.x & 1) | ((c.y & 1) << 1) | ((c.z & 1) << 2)].push_back(n);
    }
    for (const auto& members : cls) {
      in_groups(members.data(), members.size(), f);
      if (dist) {
        std::vector<Brick*> changed;
        for (std::size_t n : members) changed.push_back(bricks.find(keys[n]));
        std::vector<Request> none;
        Outbox ignored;
        sync(changed, none, ignored);
      }
    }
  }

  // --- the dense path -------------------------------------------------------------------------

  // Every point of every brick; every cell examined.
  void dense() {
    const auto& P = geo.points;
    if (dist) {
      // Every plane costs the same.
      dist->first = deal_planes(std::vector<double>(highest_plane - lowest_plane + 1, 1.0),
                                lowest_plane, ranks);
    }
    std::vector<std::uint64_t> keys;
    for (int bx = -1; bx * kBrick <= P[0] - 1; ++bx) {
      if (!owned(bx)) continue;
      for (int by = -1; by * kBrick <= P[1] - 1; ++by)
        for (int bz = -1; bz * kBrick <= P[2] - 1; ++bz) keys.push_back(brick_key(bx, by, bz));
    }
    for (std::uint64_t k : keys) get(k);
    std::vector<Brick*> list;
    for (std::uint64_t k : keys) list.push_back(bricks.find(k));
    std::atomic<std::size_t> done{0};
    tbb::parallel_for(std::size_t{0}, list.size(), [&](std::size_t n) {
      im.check_cancel();
      thread_local Batch b;
      sample_dense(*list[n], b);
      const std::size_t k = ++done;
      if (k % 256 == 0) report(0.9 * k / list.size());
    });
  }

  // One brick of the dense path: all its points evaluated, all its cells in the grid examined.
  void sample_dense(Brick& br, Batch& b) {
    const auto& P = geo.points;
    br.unpack();
    im.need(br, Impl::Around{}, b, [](auto&& at) {
      for (int i = 0; i < kSide; ++i)
        for (int j = 0; j < kSide; ++j)
          for (int k = 0; k < kSide; ++k) at(i, j, k);
    });
    im.run(b);
    br.started = true;
    for (int c = 0; c < kBrickCells; ++c) {
      const int ci[3] = {c / 64, (c / 8) % 8, c % 8};
      const int g[3] = {br.at.x * kBrick + ci[0], br.at.y * kBrick + ci[1],
                        br.at.z * kBrick + ci[2]};
      if (g[0] < -1 || g[1] < -1 || g[2] < -1 || g[0] >= P[0] || g[1] >= P[1] || g[2] >= P[2])
        continue;
      int inside = 0;
      for (int d = 0; d < 8; ++d)
        inside +=
            br.get(point_index(ci[0] + (d & 1), ci[1] + ((d >> 1) & 1), ci[2] + (d >> 2))) <= 0;
      br.visited.set(c);
      if (inside != 0 && inside != 8) br.surface.set(c);
    }
    br.pack();
  }

  // --- the sparse path ------------------------------------------------------------------------

  // The coarse lattice (level 16), the bricks it flags (level 8), then the levels 4, 2, 1 and
  // the closure in rounds of visits.
  void sparse() {
    coarse_lattice();
    report(0.05);
    std::vector<std::uint64_t> hits;
    {
      const std::vector<char> flag16 = flag_coarse_cells();
      if (dist) deal_by_flags(flag16);
      hits = level8_hits(level8_candidates(flag16));
    }
    if (dist) share_hits(hits);
    const std::vector<std::uint64_t> refined8 = dilate_hits(hits);
    report(0.1);
    visit_rounds(refined8);
    // The lattice is not needed any more.
    std::vector<float>().swap(lattice);
    std::vector<float>().swap(centre);
  }

  // Where lattice point (i, j, k) and the centre of the coarse cell it is the lower corner of
  // are kept in `lattice` and `centre`.
  std::size_t lattice_index(int i, int j, int k) const {
    return (static_cast<std::size_t>(i + 1) * n1 + (j + 1)) * n2 + (k + 1);
  }

  // Level 16: the coarse lattice and the centres of its cells (on every rank: it is small,
  // and every rank deals the planes from it; its evaluations count on rank 0).
  void coarse_lattice() {
    const auto& P = geo.points;
    const int s = kCoarse;
    for (int a = 0; a < 3; ++a) hi[a] = (P[a] - 1) / s;
    const int n0 = hi[0] + 3;
    n1 = hi[1] + 3;
    n2 = hi[2] + 3;
    lattice.resize(static_cast<std::size_t>(n0) * n1 * n2);
    centre.resize(lattice.size());
    Batch b;
    for (int i = -1; i <= hi[0] + 1; ++i)
      for (int j = -1; j <= hi[1] + 1; ++j)
        for (int k = -1; k <= hi[2] + 1; ++k) {
          im.queue(b, i * s, j * s, k * s, &lattice[lattice_index(i, j, k)]);
          if (i <= hi[0] && j <= hi[1] && k <= hi[2])
            im.queue(b, i * s + s / 2, j * s + s / 2, k * s + s / 2,
                     &centre[lattice_index(i, j, k)]);
        }
    // In parallel chunks.
    const std::size_t n = b.n;
    b.out.resize(n);
    constexpr std::size_t kChunk = 4096;
    tbb::parallel_for(std::size_t{0}, (n + kChunk - 1) / kChunk, [&](std::size_t c) {
      im.check_cancel();
      const std::size_t from = c * kChunk, m = std::min(kChunk, n - from);
      im.solid.field(b.x.data() + from, b.y.data() + from, b.z.data() + from, m,
                     b.out.data() + from);
    });
    for (std::size_t i = 0; i < n; ++i) *b.dest[i] = b.out[i];
    if (rank == 0) im.evaluations += n;
    im.lattice = lattice.data();
    im.centres = centre.data();
    im.lattice_at = [this](int i, int j, int k) { return lattice_index(i, j, k); };
    for (int a = 0; a < 3; ++a) im.lattice_hi[a] = hi[a];
  }

  // Flag the coarse cells, dilate; interior blocks for the grid's tiles.
  std::vector<char> flag_coarse_cells() {
    const int s = kCoarse;
    std::vector<char> flag16(lattice.size(), 0);
    for (int i = -1; i <= hi[0]; ++i)
      for (int j = -1; j <= hi[1]; ++j)
        for (int k = -1; k <= hi[2]; ++k) {
          Flagger f;
          bool all_inside = true;
          for (int d = 0; d < 8; ++d) {
            const int a = i + (d & 1), bb = j + ((d >> 1) & 1), c = k + (d >> 2);
            const float v = lattice[lattice_index(a, bb, c)];
            f.add(v, im.is_virtual(a * s, bb * s, c * s));
            all_inside = all_inside && v <= 0;
          }
          if (i <= hi[0] && j <= hi[1] && k <= hi[2])
            f.add(centre[lattice_index(i, j, k)],
                  im.is_virtual(i * s + s / 2, j * s + s / 2, k * s + s / 2));
          if (f.refine(true)) {
            for (int dx = -1; dx <= 1; ++dx)
              for (int dy = -1; dy <= 1; ++dy)
                for (int dz = -1; dz <= 1; ++dz) {
                  const int a = i + dx, bb = j + dy, c = k + dz;
                  if (a < -1 || bb < -1 || c < -1 || a > hi[0] || bb > hi[1] || c > hi[2]) continue;
                  flag16[lattice_index(a, bb, c)] = 1;
                }
          } else if (all_inside && i >= 0 && j >= 0 && k >= 0) {
            interior.push_back({i, j, k});
          }
        }
    // Interior blocks that the dilation flagged are not uniform after all.
    interior.erase(std::remove_if(interior.begin(), interior.end(),
                                  [&](const std::array<int, 3>& c) {
                                    return flag16[lattice_index(c[0], c[1], c[2])] != 0;
                                  }),
                   interior.end());
    return flag16;
  }

  // The planes dealt by their flagged coarse cells (where the surface is, and so the work),
  // half of a coarse cell to each of its two planes of bricks, plus a little for every plane.
  void deal_by_flags(const std::vector<char>& flag16) {
    std::vector<double> weight(highest_plane - lowest_plane + 1, 1.0);
    for (int i = -1; i <= hi[0]; ++i)
      for (int j = -1; j <= hi[1]; ++j)
        for (int k = -1; k <= hi[2]; ++k) {
          if (!flag16[lattice_index(i, j, k)]) continue;
          for (int bx : {2 * i, 2 * i + 1})
            if (bx >= lowest_plane && bx <= highest_plane) weight[bx - lowest_plane] += 32;
        }
    dist->first = deal_planes(weight, lowest_plane, ranks);
  }

  // Level 8: the bricks of flagged coarse cells (this rank's), created; sorted by key.
  std::vector<std::uint64_t> level8_candidates(const std::vector<char>& flag16) {
    std::vector<std::uint64_t> candidates;
    for (int i = -1; i <= hi[0]; ++i)
      for (int j = -1; j <= hi[1]; ++j)
        for (int k = -1; k <= hi[2]; ++k) {
          if (!flag16[lattice_index(i, j, k)]) continue;
          for (int d = 0; d < 8; ++d) {
            const int nb[3] = {2 * i + (d & 1), 2 * j + ((d >> 1) & 1), 2 * k + (d >> 2)};
            if (im.in_range(nb) && owned(nb[0]))
              candidates.push_back(brick_key(nb[0], nb[1], nb[2]));
          }
        }
    std::sort(candidates.begin(), candidates.end());
    candidates.erase(std::unique(candidates.begin(), candidates.end()), candidates.end());
    create(candidates);
    return candidates;
  }

  // The candidates flagged by their corners (Impl::flag8), in key order.
  std::vector<std::uint64_t> level8_hits(const std::vector<std::uint64_t>& candidates) {
    std::vector<char> hit(candidates.size(), 0);
    by_class(candidates, [&](const std::size_t* n, std::size_t count, Batch& b) {
      Brick* group[kGroup];
      char h[kGroup];
      for (std::size_t i = 0; i < count; ++i) group[i] = bricks.find(candidates[n[i]]);
      im.flag8(group, count, b, h);
      for (std::size_t i = 0; i < count; ++i) hit[n[i]] = h[i];
    });
    std::vector<std::uint64_t> hits;
    for (std::size_t n = 0; n < candidates.size(); ++n)
      if (hit[n]) hits.push_back(candidates[n]);
    return hits;
  }

  // Every rank's hits: a hit next to this rank's slab refines bricks in it.
  void share_hits(std::vector<std::uint64_t>& hits) const {
    Packer p;
    p.put_vector(hits);
    hits.clear();
    for (const std::string& m : dist->comm->allgather(p.data)) {
      Unpacker u(m);
      for (std::uint64_t k : u.get_vector<std::uint64_t>())
        if (kept(brick_of_key(k).x)) hits.push_back(k);
    }
  }

  // The hits dilated by one brick: the bricks that run the stride-4 level (sorted). A key's
  // neighbours along an axis are the key minus and plus that axis's unit, and shifting a sorted
  // list keeps it sorted: the dilation is three merges of three sorted lists (z, then y, then
  // x), not a sort of 27 keys a hit.
  std::vector<std::uint64_t> dilate_hits(const std::vector<std::uint64_t>& hits) const {
    constexpr std::uint64_t kField = (std::uint64_t{1} << kKeyBits) - 1;
    // The union of in - unit, in and in + unit (a key whose field is 0 has no lower neighbour).
    auto spread = [](const std::vector<std::uint64_t>& in, int shift) {
      const std::uint64_t unit = std::uint64_t{1} << shift;
      std::vector<std::uint64_t> out;
      out.reserve(3 * in.size());
      std::size_t lo = 0, mid = 0, hi = 0;
      const std::size_t n = in.size();
      auto down_ok = [&](std::size_t i) { return ((in[i] >> shift) & kField) != 0; };
      while (lo < n && !down_ok(lo)) ++lo;
      while (lo < n || mid < n || hi < n) {
        std::uint64_t next = UINT64_MAX;
        if (lo < n) next = std::min(next, in[lo] - unit);
        if (mid < n) next = std::min(next, in[mid]);
        if (hi < n) next = std::min(next, in[hi] + unit);
        if (out.empty() || out.back() != next) out.push_back(next);
        if (lo < n && in[lo] - unit == next)
          for (++lo; lo < n && !down_ok(lo);) ++lo;
        if (mid < n && in[mid] == next) ++mid;
        if (hi < n && in[hi] + unit == next) ++hi;
      }
      return out;
    };
    std::vector<std::uint64_t> sorted;
    const bool in_order = std::is_sorted(hits.begin(), hits.end());
    if (!in_order) {  // the ranks' hits gathered
      sorted = hits;
      std::sort(sorted.begin(), sorted.end());
    }
    std::vector<std::uint64_t> refined8 =
        spread(spread(spread(in_order ? hits : sorted, 0), kKeyBits), 2 * kKeyBits);
    refined8.erase(std::remove_if(refined8.begin(), refined8.end(),
                                  [&](std::uint64_t key) {
                                    const BrickCoord c = brick_of_key(key);
                                    const int nb[3] = {c.x, c.y, c.z};
                                    return !im.in_range(nb) || !owned(nb[0]);
                                  }),
                   refined8.end());
    return refined8;
  }

  static int class_of(const Brick& b) {
    return (b.at.x & 1) | ((b.at.y & 1) << 1) | ((b.at.z & 1) << 2);
  }

  // Levels 4, 2, 1 and the closure. Bricks are visited class by class (coordinate parity);
  // a visit leaves requests in the inboxes of its neighbours, which are visited when their
  // class comes (in this round, or in the next for the classes already done), until no
  // request is left. Which bricks a class visits depends only on the classes before it, so
  // the result does not depend on the thread count, nor on the number of ranks.
  void visit_rounds(const std::vector<std::uint64_t>& refined8) {
    create(refined8);
    for (std::uint64_t k : refined8) {
      Brick& b = *bricks.find(k);
      b.refined8 = true;
      b.scheduled = true;
      pending[class_of(b)].push_back(&b);
    }
    first_round = refined8.size();
    for (bool any = true; any;) {
      any = false;
      for (int k = 0; k < 8; ++k) {
        std::vector<Brick*> members;
        members.swap(pending[k]);
        if (members.empty() && !dist) continue;
        any = any || !members.empty();
        visit_class(members);
      }
      if (dist) any = dist->comm->any(any);
    }
  }

  // One class's visits, in groups in parallel; then the bricks they asked for are created (and
  // a distributed run's requests and changed bricks exchanged), and the bricks with new
  // requests wait for their class.
  void visit_class(std::vector<Brick*>& members) {
    // A fixed order, whatever order the requests came in.
    std::sort(members.begin(), members.end(),
              [](const Brick* a, const Brick* b) { return a->key < b->key; });
    for (Brick* b : members) b->scheduled = false;
    tbb::enumerable_thread_specific<Outbox> outboxes;
    in_groups(members.data(), members.size(), [&](Brick* const* group, std::size_t n, Batch& b) {
      im.visit(group, n, b, outboxes.local());
    });
    visits += members.size();
    report(0.1 + 0.75 * std::min(1.0, double(visits) / (1.25 * first_round + 1)));
    // Bricks asked for that do not exist yet; then the schedules, by class.
    std::vector<Request> missing, remote;
    for (Outbox& o : outboxes) {
      missing.insert(missing.end(), o.missing.begin(), o.missing.end());
      remote.insert(remote.end(), o.remote.begin(), o.remote.end());
    }
    std::sort(missing.begin(), missing.end(),
              [](const Request& a, const Request& b) { return a.key < b.key; });
    Outbox created;
    for (const Request& r : missing) Impl::deposit(get(r.key), r, created);
    sync(members, remote, created);
    for (Brick* b : created.schedule) pending[class_of(*b)].push_back(b);
    for (Outbox& o : outboxes)
      for (Brick* b : o.schedule) pending[class_of(*b)].push_back(b);
  }

  // Bricks that hold nothing are dropped (and the other ranks' copies); the rest sorted by key.
  BrickList list_bricks() {
    BrickList out;
    out.reserve(bricks.size());
    bricks.drain([&](std::unique_ptr<Brick> br) {
      if (br->known.any() && owned(br->at.x)) out.push_back(std::move(br));
    });
    if (opts.return_free_memory) malloc_trim(0);
    if (dist && ranks > 1) redeal_for_meshing(out, *dist, lowest_plane);
    tbb::parallel_sort(out.begin(), out.end(),
                       [](const std::unique_ptr<Brick>& a, const std::unique_ptr<Brick>& b) {
                         return a->key < b->key;
                       });
    // Links to dropped bricks go.
    for (auto& br : out) std::fill(std::begin(br->around), std::end(br->around), nullptr);
    report(0.9);
    return out;
  }
};

BrickList BrickSampler::run() {
  Sampling s(solid_, geo_, opts_, interior_);
  if (s.dense_path())
    s.dense();
  else
    s.sparse();
  evaluations_ = s.im.evaluations;
  return s.list_bricks();
}

}  // namespace qjulia::detail
