#include "base/bvh.h"

#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

#include "base/geometry.h"

namespace qjulia::detail {

namespace {

using Node = TriangleBvh::Node;

struct Box {
  float lo[3], hi[3];
};

inline void make_empty(float lo[3], float hi[3]) {
  for (int k = 0; k < 3; ++k) {
    lo[k] = std::numeric_limits<float>::max();
    hi[k] = std::numeric_limits<float>::lowest();
  }
}

inline void grow(float lo[3], float hi[3], const float blo[3], const float bhi[3]) {
  for (int k = 0; k < 3; ++k) {
    lo[k] = std::min(lo[k], blo[k]);
    hi[k] = std::max(hi[k], bhi[k]);
  }
}

// Half the surface area of a box (0 for an empty one).
inline float half_area(const float lo[3], const float hi[3]) {
  const float x = hi[0] - lo[0], y = hi[1] - lo[1], z = hi[2] - lo[2];
  return x < 0 ? 0.0f : x * y + y * z + z * x;
}

// Squared distance from p to the box [lo, hi] (0 inside).
inline float box_distance_sq(const float p[3], const float lo[3], const float hi[3]) {
  float d = 0;
  for (int k = 0; k < 3; ++k) {
    const float e = std::max(std::max(lo[k] - p[k], p[k] - hi[k]), 0.0f);
    d += e * e;
  }
  return d;
}

using Positions = std::vector<std::array<float, 3>>;
using Triangles = std::vector<std::array<uint32_t, 3>>;

Box triangle_box(const Positions& positions, const std::array<uint32_t, 3>& t) {
  Box b;
  for (int k = 0; k < 3; ++k) {
    b.lo[k] = std::min({positions[t[0]][k], positions[t[1]][k], positions[t[2]][k]});
    b.hi[k] = std::max({positions[t[0]][k], positions[t[1]][k], positions[t[2]][k]});
  }
  return b;
}

// The box of a set of triangles and the box of their centres (times two).
struct Bounds {
  Box box, centres;
  uint32_t count = 0;
  void clear() {
    make_empty(box.lo, box.hi);
    make_empty(centres.lo, centres.hi);
    count = 0;
  }
  void add(const Box& b) {
    float c[3];
    for (int k = 0; k < 3; ++k) c[k] = b.lo[k] + b.hi[k];
    grow(box.lo, box.hi, b.lo, b.hi);
    grow(centres.lo, centres.hi, c, c);
    ++count;
  }
  void add(const Bounds& o) {
    grow(box.lo, box.hi, o.box.lo, o.box.hi);
    grow(centres.lo, centres.hi, o.centres.lo, o.centres.hi);
    count += o.count;
  }
};

// Appends a subtree built on its own, moving its child links by its new offset.
void splice(std::vector<Node>& out, const std::vector<Node>& sub) {
  const uint32_t offset = static_cast<uint32_t>(out.size());
  for (Node n : sub) {
    if (n.count == 0) n.first += offset;
    out.push_back(n);
  }
}

Node make_node(const Bounds& bounds, uint32_t first, uint32_t count) {
  Node node;
  for (int k = 0; k < 3; ++k) {
    node.lo[k] = bounds.box.lo[k];
    node.hi[k] = bounds.box.hi[k];
  }
  node.first = first;
  node.count = count;
  return node;
}

// The surface area heuristic build of a small set of triangles whose centres share one Morton
// code: binned along the widest axis of the centres, the split that minimises
// area(left) * count(left) + area(right) * count(right) (the expected work of a query), the
// median when no split helps.
class SahBuilder {
 public:
  struct Ref {
    Box box;
    uint32_t face;
  };

  // `refs` are the triangles of the slots first, first + 1, ... of the tree.
  SahBuilder(std::vector<Ref>& refs, uint32_t first) : refs_(refs), first_(first) {}

  // Appends the subtree of refs[begin, end) (whose bounds are `bounds`) to `out`; returns the
  // index of its root.
  uint32_t build(uint32_t begin, uint32_t end, const Bounds& bounds, int depth,
                 std::vector<Node>& out) {
    const uint32_t index = static_cast<uint32_t>(out.size());
    out.push_back(make_node(bounds, first_ + begin, end - begin));
    const float* clo = bounds.centres.lo;
    const float* chi = bounds.centres.hi;
    int axis = 0;
    for (int k = 1; k < 3; ++k)
      if (chi[k] - clo[k] > chi[axis] - clo[axis]) axis = k;
    if (end - begin <= static_cast<uint32_t>(TriangleBvh::kLeafSize) || depth > 60 ||
        !(chi[axis] > clo[axis]))  // small, too deep, or all centres at one point: a leaf
      return index;
    Bounds left, right;
    const uint32_t mid = split(begin, end, bounds, axis, left, right);
    build(begin, mid, left, depth + 1, out);  // the left child is index + 1
    const uint32_t right_child = build(mid, end, right, depth + 1, out);
    out[index].first = right_child;
    out[index].count = 0;
    return index;
  }

 private:
  static constexpr int kBins = 16;

  static int bin_of(const Box& b, int ax, float lo, float scale) {
    return std::min(kBins - 1, static_cast<int>((b.lo[ax] + b.hi[ax] - lo) * scale));
  }

  // Partitions refs[begin, end), fills the bounds of both sides and returns the first index of
  // the right side.
  uint32_t split(uint32_t begin, uint32_t end, const Bounds& bounds, int axis, Bounds& left,
                 Bounds& right) {
    const float lo = bounds.centres.lo[axis];
    const float scale = kBins / (bounds.centres.hi[axis] - lo);  // the extent is > 0
    Bounds bins[kBins];
    for (auto& b : bins) b.clear();
    for (uint32_t i = begin; i < end; ++i)
      bins[bin_of(refs_[i].box, axis, lo, scale)].add(refs_[i].box);
    // Sweep from the right to get the cost of every right side, then from the left.
    float right_cost[kBins];
    Bounds acc;
    acc.clear();
    for (int b = kBins - 1; b > 0; --b) {
      acc.add(bins[b]);
      right_cost[b] = acc.count ? half_area(acc.box.lo, acc.box.hi) * acc.count : 0;
    }
    float best_cost = std::numeric_limits<float>::max();
    int best_bin = -1;
    acc.clear();
    for (int b = 0; b + 1 < kBins; ++b) {
      acc.add(bins[b]);
      if (acc.count == 0 || acc.count == end - begin) continue;
      const float cost = half_area(acc.box.lo, acc.box.hi) * acc.count + right_cost[b + 1];
      if (cost < best_cost) {
        best_cost = cost;
        best_bin = b;
      }
    }
    left.clear();
    right.clear();
    if (best_bin >= 0) {
      for (int b = 0; b < kBins; ++b) (b <= best_bin ? left : right).add(bins[b]);
      auto it = std::partition(refs_.begin() + begin, refs_.begin() + end, [&](const Ref& r) {
        return bin_of(r.box, axis, lo, scale) <= best_bin;
      });
      return static_cast<uint32_t>(it - refs_.begin());
    }
    // No useful split (all centres in one bin): the median.
    const uint32_t mid = begin + (end - begin) / 2;
    std::nth_element(refs_.begin() + begin, refs_.begin() + mid, refs_.begin() + end,
                     [&](const Ref& x, const Ref& y) {
                       return x.box.lo[axis] + x.box.hi[axis] < y.box.lo[axis] + y.box.hi[axis];
                     });
    for (uint32_t i = begin; i < mid; ++i) left.add(refs_[i].box);
    for (uint32_t i = mid; i < end; ++i) right.add(refs_[i].box);
    return mid;
  }

  std::vector<Ref>& refs_;
  const uint32_t first_;
};

// Sorts keys (Morton code << 32 | face) by their code: a stable radix sort of bits 32..61, ten
// bits a pass, so equal codes stay in face order.
void sort_by_code(std::vector<uint64_t>& keys) {
  std::vector<uint64_t> tmp(keys.size());
  for (int shift = 32; shift < 62; shift += 10) {
    std::vector<std::size_t> start(1025, 0);
    for (uint64_t k : keys) ++start[((k >> shift) & 1023) + 1];
    for (std::size_t b = 0; b < 1024; ++b) start[b + 1] += start[b];
    for (uint64_t k : keys) tmp[start[(k >> shift) & 1023]++] = k;
    keys.swap(tmp);
  }
}

// Top-down build over the faces order[begin, end), sorted along a Morton curve of their box
// centres (`codes`): a node is split where the codes change their highest bit, a spatial median
// found by binary search without a pass over the triangles (the boxes are joined bottom up).
// Triangles that share one code (a cluster finer than 1/1024 of the mesh) are split by the
// surface area heuristic instead. Slot i of the tree holds the face order[i]. Each subtree is
// laid out depth first (a node, its left subtree, its right subtree); large subtrees are built
// in parallel into vectors of their own and spliced, so the layout is the same as a serial
// build.
class Builder {
 public:
  Builder(const Positions& positions, const Triangles& triangles, std::vector<uint32_t>& order,
          const std::vector<uint32_t>& codes)
      : positions_(positions), triangles_(triangles), order_(order), codes_(codes) {}

  // Appends the subtree of order[begin, end) to `out`, sets `bounds` to its bounds; returns the
  // index of its root.
  uint32_t build(uint32_t begin, uint32_t end, int depth, std::vector<Node>& out,
                 Bounds& bounds) const {
    if (end - begin <= static_cast<uint32_t>(TriangleBvh::kLeafSize)) {
      bounds.clear();
      for (uint32_t i = begin; i < end; ++i)
        bounds.add(triangle_box(positions_, triangles_[order_[i]]));
      out.push_back(make_node(bounds, begin, end - begin));
      return static_cast<uint32_t>(out.size() - 1);
    }
    if (codes_[begin] == codes_[end - 1]) return build_cluster(begin, end, depth, out, bounds);
    // The codes in [begin, end) share every bit above the highest one that differs.
    const uint32_t bit = 1u << (31 - __builtin_clz(codes_[begin] ^ codes_[end - 1]));
    const uint32_t mid =
        static_cast<uint32_t>(std::partition_point(codes_.begin() + begin, codes_.begin() + end,
                                                   [bit](uint32_t c) { return (c & bit) == 0; }) -
                              codes_.begin());
    const uint32_t index = static_cast<uint32_t>(out.size());
    out.push_back({});
    Bounds right;
    uint32_t right_child;
    if (end - begin >= kParallelFaces) {
      std::vector<Node> lnodes, rnodes;
      tbb::parallel_invoke([&] { build(begin, mid, depth + 1, lnodes, bounds); },
                           [&] { build(mid, end, depth + 1, rnodes, right); });
      splice(out, lnodes);
      right_child = static_cast<uint32_t>(out.size());
      splice(out, rnodes);
    } else {
      build(begin, mid, depth + 1, out, bounds);  // the left child is index + 1
      right_child = build(mid, end, depth + 1, out, right);
    }
    bounds.add(right);
    out[index] = make_node(bounds, right_child, 0);
    return index;
  }

 private:
  static constexpr uint32_t kParallelFaces = 1 << 15;  // smaller subtrees are built serially

  // The faces order[begin, end) share one code: the surface area heuristic, over their boxes.
  uint32_t build_cluster(uint32_t begin, uint32_t end, int depth, std::vector<Node>& out,
                         Bounds& bounds) const {
    std::vector<SahBuilder::Ref> refs(end - begin);
    bounds.clear();
    for (uint32_t i = begin; i < end; ++i) {
      refs[i - begin] = {triangle_box(positions_, triangles_[order_[i]]), order_[i]};
      bounds.add(refs[i - begin].box);
    }
    std::vector<Node> sub;
    SahBuilder(refs, begin).build(0, end - begin, bounds, depth, sub);
    for (uint32_t i = begin; i < end; ++i) order_[i] = refs[i - begin].face;
    const uint32_t index = static_cast<uint32_t>(out.size());
    splice(out, sub);
    return index;
  }

  const Positions& positions_;
  const Triangles& triangles_;
  std::vector<uint32_t>& order_;
  const std::vector<uint32_t>& codes_;
};

}  // namespace

TriangleBvh::TriangleBvh(const std::vector<std::array<float, 3>>& positions,
                         const std::vector<std::array<uint32_t, 3>>& triangles) {
  const std::size_t nv = positions.size();
  std::vector<uint32_t> order;  // the faces in the tree; once built, the face of every slot
  order.reserve(triangles.size());
  Box frame;  // holds every box centre (times two)
  make_empty(frame.lo, frame.hi);
  for (std::size_t f = 0; f < triangles.size(); ++f) {
    const auto& t = triangles[f];
    if (t[0] >= nv || t[1] >= nv || t[2] >= nv) continue;
    order.push_back(static_cast<uint32_t>(f));
    for (uint32_t v : t) grow(frame.lo, frame.hi, positions[v].data(), positions[v].data());
  }
  if (order.empty()) return;
  for (int k = 0; k < 3; ++k) {
    frame.lo[k] *= 2;
    frame.hi[k] *= 2;
  }
  // The faces along a Morton curve of their box centres (10 bits per axis), ties by face.
  const std::size_t n = order.size();
  std::vector<uint32_t> codes(n);
  {
    std::vector<uint64_t> keys(n);
    tbb::parallel_for(std::size_t(0), n, [&](std::size_t i) {
      const Box b = triangle_box(positions, triangles[order[i]]);
      uint32_t q[3];
      for (int k = 0; k < 3; ++k) {
        const float extent = frame.hi[k] - frame.lo[k];
        const float u = extent > 0 ? (b.lo[k] + b.hi[k] - frame.lo[k]) / extent : 0.0f;
        q[k] = static_cast<uint32_t>(std::clamp(u * 1024.0f, 0.0f, 1023.0f));
      }
      keys[i] = morton_code(q[0], q[1], q[2]) << 32 | order[i];
    });
    sort_by_code(keys);
    for (std::size_t i = 0; i < n; ++i) {
      order[i] = static_cast<uint32_t>(keys[i]);
      codes[i] = static_cast<uint32_t>(keys[i] >> 32);
    }
  }
  nodes_.reserve(2 * n / kLeafSize + 2);
  Bounds root;
  Builder(positions, triangles, order, codes).build(0, static_cast<uint32_t>(n), 0, nodes_, root);
  codes.clear();
  codes.shrink_to_fit();
  tri_.resize(n);
  tbb::parallel_for(std::size_t(0), n, [&](std::size_t i) {
    const auto& t = triangles[order[i]];
    const auto &a = positions[t[0]], &b = positions[t[1]], &c = positions[t[2]];
    for (int k = 0; k < 3; ++k) {
      tri_[i].a[k] = a[k];
      tri_[i].ab[k] = b[k] - a[k];
      tri_[i].ac[k] = c[k] - a[k];
    }
  });
}

ClosestHit TriangleBvh::closest(const std::array<float, 3>& point, uint32_t hint) const {
  const float p[3] = {point[0], point[1], point[2]};
  ClosestHit best{std::numeric_limits<float>::infinity(), UINT32_MAX};
  if (hint < tri_.size()) {
    const Tri& t = tri_[hint];
    best = {point_triangle_distance_sq(p, t.a, t.ab, t.ac), hint};
  }
  struct Entry {
    uint32_t node;
    float d;
  };
  Entry stack[128];
  int top = 0;
  stack[top++] = {0, box_distance_sq(p, nodes_[0].lo, nodes_[0].hi)};
  while (top > 0) {
    const Entry e = stack[--top];
    if (e.d >= best.distance_sq) continue;
    const Node* node = &nodes_[e.node];
    uint32_t n = e.node;
    // Descend towards the nearer child, pushing the farther one.
    while (node->count == 0) {
      const uint32_t l = n + 1, r = node->first;
      const float dl = box_distance_sq(p, nodes_[l].lo, nodes_[l].hi);
      const float dr = box_distance_sq(p, nodes_[r].lo, nodes_[r].hi);
      uint32_t near = l, far = r;
      float dn = dl, df = dr;
      if (dr < dl) {
        std::swap(near, far);
        std::swap(dn, df);
      }
      if (df < best.distance_sq) stack[top++] = {far, df};
      if (dn >= best.distance_sq) {
        node = nullptr;
        break;
      }
      n = near;
      node = &nodes_[n];
    }
    if (!node) continue;
    for (uint32_t i = node->first; i < node->first + node->count; ++i) {
      const Tri& t = tri_[i];
      const float d = point_triangle_distance_sq(p, t.a, t.ab, t.ac);
      if (d < best.distance_sq) best = {d, i};
    }
  }
  return best;
}

std::vector<float> TriangleBvh::distances(const std::vector<std::array<float, 3>>& points,
                                          const CancelToken* cancel,
                                          const std::function<void(double)>& step) const {
  std::vector<float> d(points.size());
  distances(
      points.size(),
      [&](std::size_t begin, std::size_t end, std::array<float, 3>* out) {
        std::copy(points.begin() + begin, points.begin() + end, out);
      },
      [&](std::size_t begin, const float* batch, std::size_t n) {
        std::copy(batch, batch + n, d.begin() + begin);
      },
      cancel, step);
  return d;
}

void TriangleBvh::distances(std::size_t count, const PointSource& source, const DistanceSink& sink,
                            const CancelToken* cancel,
                            const std::function<void(double)>& step) const {
  constexpr std::size_t kBatch = 1 << 16, kBlock = 256;
  std::vector<std::array<float, 3>> points(std::min(count, kBatch));
  std::vector<float> d(points.size());
  for (std::size_t begin = 0; begin < count; begin += kBatch) {
    throw_if_cancelled(cancel);
    const std::size_t end = std::min(count, begin + kBatch);
    const std::size_t blocks = (end - begin + kBlock - 1) / kBlock;
    tbb::parallel_for(std::size_t(0), blocks, [&](std::size_t block) {
      const std::size_t first = block * kBlock, last = std::min(end - begin, first + kBlock);
      if (empty()) {  // no surface: every distance is infinite, and no point is needed
        std::fill(d.begin() + first, d.begin() + last, std::numeric_limits<float>::infinity());
        return;
      }
      source(begin + first, begin + last, points.data() + first);
      // Consecutive points are close: the previous hit is a good start.
      uint32_t hint = UINT32_MAX;
      for (std::size_t i = first; i < last; ++i) {
        const ClosestHit hit = closest(points[i], hint);
        d[i] = std::sqrt(hit.distance_sq);
        hint = hit.slot;
      }
    });
    sink(begin, d.data(), end - begin);
    if (step) step(static_cast<double>(end) / count);
  }
}

}  // namespace qjulia::detail
