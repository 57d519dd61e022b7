#include "mesh/collapse.h"

#include <algorithm>
#include <string>

#include "base/geometry.h"
#include "qjulia/base/error.h"
#include "qjulia/base/progress.h"

namespace qjulia::detail {
namespace {

constexpr uint32_t kNone = 0xffffffffu;

/// An area-weighted sum of squared distances to planes: x.A.x + 2 b.x + c, and the area w.
struct Quadric {
  double a00 = 0, a01 = 0, a02 = 0, a11 = 0, a12 = 0, a22 = 0, b0 = 0, b1 = 0, b2 = 0, c = 0, w = 0;
  void add(const Quadric& o) {
    a00 += o.a00;
    a01 += o.a01;
    a02 += o.a02;
    a11 += o.a11;
    a12 += o.a12;
    a22 += o.a22;
    b0 += o.b0;
    b1 += o.b1;
    b2 += o.b2;
    c += o.c;
    w += o.w;
  }
  /// The plane n.x + d = 0 (n of length 1) with weight `area`.
  void add_plane(const Vec3d& n, double d, double area) {
    a00 += area * n[0] * n[0];
    a01 += area * n[0] * n[1];
    a02 += area * n[0] * n[2];
    a11 += area * n[1] * n[1];
    a12 += area * n[1] * n[2];
    a22 += area * n[2] * n[2];
    b0 += area * n[0] * d;
    b1 += area * n[1] * d;
    b2 += area * n[2] * d;
    c += area * d * d;
    w += area;
  }
  double at(const Vec3d& p) const {
    const double x = p[0], y = p[1], z = p[2];
    return x * (a00 * x + 2 * (a01 * y + a02 * z + b0)) + y * (a11 * y + 2 * (a12 * z + b1)) +
           z * (a22 * z + 2 * b2) + c;
  }
};

class Collapser {
 public:
  Collapser(const TriMesh& mesh, const CollapseOptions& opts)
      : opts_(opts),
        nv_(mesh.positions.size()),
        tri_(mesh.triangles),
        alive_(tri_.size(), 1),
        head_(nv_, kNone),
        next_(3 * tri_.size(), kNone),
        pos_(nv_),
        q_(nv_),
        key_(nv_, 0),
        target_(nv_, kNone),
        slot_(nv_, kNone),
        removed_(nv_, 0),
        mark_(nv_, 0),
        faces_(tri_.size()) {
    for (std::size_t v = 0; v < nv_; ++v) pos_[v] = to_vec3d(mesh.positions[v]);
    for (std::size_t f = 0; f < tri_.size(); ++f) {
      const auto& t = tri_[f];
      for (int k = 0; k < 3; ++k) {
        const auto c = static_cast<uint32_t>(3 * f + k);
        next_[c] = head_[t[k]];
        head_[t[k]] = c;
      }
      const Vec3d n = cross(p(t[1]) - p(t[0]), p(t[2]) - p(t[0]));
      const double len = length(n);
      if (!(len > 0)) continue;
      const Vec3d unit = normalized(n);
      const double d = -dot(unit, p(t[0]));
      for (int k = 0; k < 3; ++k) q_[t[k]].add_plane(unit, d, 0.5 * len);
    }
  }

  std::vector<std::array<uint32_t, 3>> run() {
    const double bound = opts_.max_error < 1e150 ? opts_.max_error * opts_.max_error : 1e300;
    // Every vertex's cheapest collapse, then the queue built at once (Floyd's heap order).
    building_ = true;
    for (uint32_t v = 0; v < nv_; ++v)
      if (head_[v] != kNone) push_best(v);
    building_ = false;
    for (std::size_t i = heap_.size() / 2; i-- > 0;) sift_down(i);
    std::size_t pops = 0;
    while (faces_ > opts_.target_faces && !heap_.empty()) {
      if ((++pops & 0x3fff) == 0) throw_if_cancelled(opts_.cancel);
      const uint32_t u = heap_[0];
      if (key_[u] > bound) break;
      const uint32_t v = target_[u];
      if (!valid(u, v)) {
        push_best(u, true);  // the cheapest valid one, or none
        continue;
      }
      erase(u);
      collapse(u, v);
    }
    std::vector<std::array<uint32_t, 3>> out;
    out.reserve(faces_);
    for (std::size_t f = 0; f < tri_.size(); ++f)
      if (alive_[f]) out.push_back(tri_[f]);
    return out;
  }

 private:
  const Vec3d& p(uint32_t v) const { return pos_[v]; }

  template <class F>
  void each_face(uint32_t v, F&& fn) const {
    for (uint32_t c = head_[v]; c != kNone; c = next_[c])
      if (alive_[c / 3]) fn(c / 3, c % 3);
  }

  uint32_t next_stamp() {
    if (stamp_ == 0xffffffffu) {  // after four billion: the marks start again
      std::fill(mark_.begin(), mark_.end(), 0);
      stamp_ = 0;
    }
    return ++stamp_;
  }

  /// Calls fn(x) once for each neighbour x of v.
  template <class F>
  void each_neighbour(uint32_t v, F&& fn) {
    const uint32_t s = next_stamp();
    each_face(v, [&](std::size_t f, int k) {
      for (int j = 1; j <= 2; ++j) {
        const uint32_t x = tri_[f][(k + j) % 3];
        if (mark_[x] == s) continue;
        mark_[x] = s;
        fn(x);
      }
    });
  }

  bool is_locked(uint32_t v) const { return opts_.locked && (*opts_.locked)[v]; }

  double cost(uint32_t from, uint32_t to) const {
    const Quadric& a = q_[from];
    const Quadric& b = q_[to];
    const double w = a.w + b.w;
    return w > 0 ? std::max(0.0, (a.at(p(to)) + b.at(p(to))) / w) : 0.0;
  }

  /// Whether merging `u` into its neighbour `v` keeps the topology and turns no face over.
  bool valid(uint32_t u, uint32_t v) {
    // No face of u (other than the two that vanish) turns over or degenerates when u moves to v.
    const uint32_t s1 = next_stamp(), s2 = next_stamp();
    int degree = 0;
    bool flips = false;
    each_face(u, [&](std::size_t f, int k) {
      ++degree;
      const uint32_t a = tri_[f][(k + 1) % 3], b = tri_[f][(k + 2) % 3];
      mark_[a] = s1;
      mark_[b] = s1;
      if (flips || a == v || b == v) return;
      const Vec3d before = cross(p(a) - p(u), p(b) - p(u));
      const Vec3d after = cross(p(a) - p(v), p(b) - p(v));
      flips = !(dot(before, after) > 0) || !(dot(after, after) > 0);
    });
    if (flips || mark_[v] != s1) return false;  // a face turned over, or not neighbours
    // The link condition: u and v share exactly two neighbours, a and b (the third corners of
    // the two faces of their edge), ...
    uint32_t common[2] = {kNone, kNone};
    int n = 0;
    each_face(v, [&](std::size_t f, int k) {
      for (int j = 1; j <= 2; ++j) {
        const uint32_t x = tri_[f][(k + j) % 3];
        if (mark_[x] != s1) continue;
        mark_[x] = s2;
        if (n < 2) common[n] = x;
        ++n;
      }
    });
    if (n != 2) return false;
    // ... and the edge between a and b is not in both their links (u's faces and v's faces both
    // holding a and b: a tetrahedron, or a valence-3 vertex whose merge doubles a face). Only a
    // vertex of three faces has a face holding both.
    auto has_ab = [&](uint32_t w) {
      bool found = false;
      each_face(w, [&](std::size_t f, int) {
        const auto& t = tri_[f];
        const bool a = t[0] == common[0] || t[1] == common[0] || t[2] == common[0];
        const bool b = t[0] == common[1] || t[1] == common[1] || t[2] == common[1];
        found = found || (a && b);
      });
      return found;
    };
    return !(degree <= 3 && has_ab(u) && has_ab(v));
  }

  /// Queues the cheapest collapse of `u` into a neighbour; with `checked`, the cheapest valid one
  /// (else its validity is checked when it comes up). Without one, u leaves the queue.
  void push_best(uint32_t u, bool checked = false) {
    if (removed_[u] || is_locked(u)) return;
    order_.clear();
    each_neighbour(u, [&](uint32_t x) { order_.push_back({cost(u, x), x}); });
    if (!checked) {
      const auto best = std::min_element(order_.begin(), order_.end());
      if (best != order_.end()) return queue(u, best->first, best->second);
    } else {
      std::sort(order_.begin(), order_.end());
      for (const auto& [c, x] : order_)
        if (valid(u, x)) return queue(u, c, x);
    }
    erase(u);
  }

  // The queue: a binary heap of vertices by (cost, vertex), each vertex at most once.
  bool before(uint32_t a, uint32_t b) const {
    return key_[a] < key_[b] || (key_[a] == key_[b] && a < b);
  }
  void place(std::size_t i, uint32_t v) {
    heap_[i] = v;
    slot_[v] = static_cast<uint32_t>(i);
  }
  void sift(std::size_t i) {
    const uint32_t v = heap_[i];
    while (i > 0 && before(v, heap_[(i - 1) / 2])) {
      place(i, heap_[(i - 1) / 2]);
      i = (i - 1) / 2;
    }
    place(i, v);
    sift_down(i);
  }
  void sift_down(std::size_t i) {
    const uint32_t v = heap_[i];
    for (;;) {
      std::size_t c = 2 * i + 1;
      if (c >= heap_.size()) break;
      if (c + 1 < heap_.size() && before(heap_[c + 1], heap_[c])) ++c;
      if (!before(heap_[c], v)) break;
      place(i, heap_[c]);
      i = c;
    }
    place(i, v);
  }
  void queue(uint32_t u, double cost, uint32_t to) {
    key_[u] = cost;
    target_[u] = to;
    if (slot_[u] == kNone) {
      heap_.push_back(u);
      slot_[u] = static_cast<uint32_t>(heap_.size() - 1);
    }
    if (!building_) sift(slot_[u]);
  }
  void erase(uint32_t u) {
    const uint32_t i = slot_[u];
    if (i == kNone) return;
    slot_[u] = kNone;
    const uint32_t last = heap_.back();
    heap_.pop_back();
    if (last == u) return;
    place(i, last);
    sift(i);
  }

  void collapse(uint32_t u, uint32_t v) {
    for (uint32_t c = head_[u]; c != kNone; c = next_[c]) {
      const std::size_t f = c / 3;
      if (!alive_[f]) continue;
      auto& t = tri_[f];
      if (t[0] == v || t[1] == v || t[2] == v) {
        alive_[f] = 0;
        --faces_;
      } else {
        t[c % 3] = v;
      }
    }
    // v's corners: its own and u's that are still alive, relinked.
    uint32_t first = kNone, last = kNone;
    auto keep = [&](uint32_t list) {
      for (uint32_t c = list, nc; c != kNone; c = nc) {
        nc = next_[c];
        if (!alive_[c / 3]) continue;
        if (last == kNone)
          first = c;
        else
          next_[last] = c;
        last = c;
      }
    };
    keep(head_[v]);
    keep(head_[u]);
    if (last != kNone) next_[last] = kNone;
    head_[v] = first;
    head_[u] = kNone;
    removed_[u] = 1;
    q_[v].add(q_[u]);
    // Every collapse into v or its neighbours changes its cost or validity: queued again.
    push_best(v);
    ring_.clear();
    each_neighbour(v, [&](uint32_t x) { ring_.push_back(x); });
    // A neighbour whose best collapse went to u or v, or that had none, looks again at all of
    // its own; for the others only the collapse into v changed its cost.
    for (uint32_t x : ring_) {
      if (removed_[x] || is_locked(x)) continue;
      if (slot_[x] == kNone || target_[x] == u || target_[x] == v) {
        push_best(x);
      } else {
        const double c = cost(x, v);
        if (c < key_[x] || (c == key_[x] && v < target_[x])) queue(x, c, v);
      }
    }
  }

  const CollapseOptions& opts_;
  std::size_t nv_;
  std::vector<std::array<uint32_t, 3>> tri_;
  std::vector<uint8_t> alive_;
  std::vector<uint32_t> head_, next_;  // each vertex's corners, as a list
  std::vector<Vec3d> pos_;
  std::vector<Quadric> q_;
  std::vector<double> key_;
  std::vector<uint32_t> target_, slot_;
  std::vector<uint32_t> heap_;
  bool building_ = false;  // queue() leaves the heap order to run()
  std::vector<uint8_t> removed_;
  std::vector<uint32_t> mark_;
  uint32_t stamp_ = 0;
  std::size_t faces_;
  std::vector<std::pair<double, uint32_t>> order_;
  std::vector<uint32_t> ring_;
};

}  // namespace

std::vector<std::array<uint32_t, 3>> collapse_edges(const TriMesh& mesh,
                                                    const CollapseOptions& opts) {
  // A face's corners are numbered in 32 bits, one value kept for "none".
  if (mesh.triangles.size() > (kNone - 1) / 3)
    throw TooLarge("decimate: a pass over more than " + std::to_string((kNone - 1) / 3) +
                   " faces at once is not supported, got " + std::to_string(mesh.triangles.size()));
  return Collapser(mesh, opts).run();
}

}  // namespace qjulia::detail
