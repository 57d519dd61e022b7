#include "base/bvh.h"

#include <algorithm>
#include <cstdint>
#include <limits>

namespace qjulia::detail {

namespace {

inline float dot3(const float a[3], const float b[3]) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
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

}  // namespace

float point_triangle_distance_sq(const float p[3], const float a[3], const float ab[3],
                                 const float ac[3]) {
  const float ap[3] = {p[0] - a[0], p[1] - a[1], p[2] - a[2]};
  const float d1 = dot3(ab, ap), d2 = dot3(ac, ap);
  auto dist_to = [&](float s, float t) {  // |a + s ab + t ac - p|^2
    float d = 0;
    for (int k = 0; k < 3; ++k) {
      const float e = s * ab[k] + t * ac[k] - ap[k];
      d += e * e;
    }
    return d;
  };
  if (d1 <= 0 && d2 <= 0) return dot3(ap, ap);  // vertex a
  const float bp[3] = {ap[0] - ab[0], ap[1] - ab[1], ap[2] - ab[2]};
  const float d3 = dot3(ab, bp), d4 = dot3(ac, bp);
  if (d3 >= 0 && d4 <= d3) return dot3(bp, bp);  // vertex b
  const float vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return dist_to(d1 / (d1 - d3), 0);  // edge ab
  const float cp[3] = {ap[0] - ac[0], ap[1] - ac[1], ap[2] - ac[2]};
  const float d5 = dot3(ab, cp), d6 = dot3(ac, cp);
  if (d6 >= 0 && d5 <= d6) return dot3(cp, cp);  // vertex c
  const float vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return dist_to(0, d2 / (d2 - d6));  // edge ac
  const float va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {  // edge bc
    const float w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    return dist_to(1 - w, w);
  }
  const float sum = va + vb + vc;
  if (!(sum > 0)) {  // a degenerate triangle: the closest of its three edges
    auto seg = [&](const float o[3], const float dir[3]) {
      const float len = dot3(dir, dir);
      const float q[3] = {p[0] - o[0], p[1] - o[1], p[2] - o[2]};
      const float t = len > 0 ? std::clamp(dot3(q, dir) / len, 0.0f, 1.0f) : 0.0f;
      float d = 0;
      for (int k = 0; k < 3; ++k) {
        const float e = q[k] - t * dir[k];
        d += e * e;
      }
      return d;
    };
    const float b[3] = {a[0] + ab[0], a[1] + ab[1], a[2] + ab[2]};
    const float bc[3] = {ac[0] - ab[0], ac[1] - ab[1], ac[2] - ab[2]};
    return std::min({seg(a, ab), seg(a, ac), seg(b, bc)});
  }
  const float denom = 1.0f / sum;
  return std::max(dist_to(vb * denom, vc * denom), 0.0f);  // inside the face
}

TriangleBvh::TriangleBvh(const std::vector<std::array<float, 3>>& positions,
                         const std::vector<std::array<uint32_t, 3>>& triangles) {
  const std::size_t nv = positions.size();
  std::vector<Tri> tris;
  std::vector<std::array<float, 3>> centroid;
  tris.reserve(triangles.size());
  centroid.reserve(triangles.size());
  for (std::size_t f = 0; f < triangles.size(); ++f) {
    const auto& t = triangles[f];
    if (t[0] >= nv || t[1] >= nv || t[2] >= nv) continue;
    const auto &a = positions[t[0]], &b = positions[t[1]], &c = positions[t[2]];
    Tri tri;
    for (int k = 0; k < 3; ++k) {
      tri.a[k] = a[k];
      tri.ab[k] = b[k] - a[k];
      tri.ac[k] = c[k] - a[k];
    }
    tri.face = static_cast<uint32_t>(f);
    tris.push_back(tri);
    centroid.push_back(
        {(a[0] + b[0] + c[0]) / 3, (a[1] + b[1] + c[1]) / 3, (a[2] + b[2] + c[2]) / 3});
  }
  if (tris.empty()) return;
  std::vector<std::array<float, 6>> boxes(tris.size());  // lo, hi of each triangle
  for (std::size_t i = 0; i < tris.size(); ++i)
    for (int k = 0; k < 3; ++k) {
      const Tri& t = tris[i];
      const float b = t.a[k] + t.ab[k], c = t.a[k] + t.ac[k];
      boxes[i][k] = std::min({t.a[k], b, c});
      boxes[i][3 + k] = std::max({t.a[k], b, c});
    }
  std::vector<uint32_t> order(tris.size());
  for (uint32_t i = 0; i < order.size(); ++i) order[i] = i;
  nodes_.reserve(2 * tris.size() / kLeafSize + 2);
  build(order, centroid, boxes, 0, static_cast<uint32_t>(order.size()), 0);
  tri_.resize(order.size());
  for (std::size_t i = 0; i < order.size(); ++i) tri_[i] = tris[order[i]];
}

uint32_t TriangleBvh::build(std::vector<uint32_t>& order,
                            const std::vector<std::array<float, 3>>& centroid,
                            const std::vector<std::array<float, 6>>& boxes, uint32_t begin,
                            uint32_t end, int depth) {
  const uint32_t index = static_cast<uint32_t>(nodes_.size());
  nodes_.push_back({});
  Node node;
  float clo[3], chi[3];
  for (int k = 0; k < 3; ++k) {
    node.lo[k] = clo[k] = std::numeric_limits<float>::max();
    node.hi[k] = chi[k] = std::numeric_limits<float>::lowest();
  }
  for (uint32_t i = begin; i < end; ++i) {
    const auto& box = boxes[order[i]];
    for (int k = 0; k < 3; ++k) {
      node.lo[k] = std::min(node.lo[k], box[k]);
      node.hi[k] = std::max(node.hi[k], box[3 + k]);
      clo[k] = std::min(clo[k], centroid[order[i]][k]);
      chi[k] = std::max(chi[k], centroid[order[i]][k]);
    }
  }
  int axis = 0;
  for (int k = 1; k < 3; ++k)
    if (chi[k] - clo[k] > chi[axis] - clo[axis]) axis = k;
  if (end - begin <= static_cast<uint32_t>(kLeafSize) || depth > 60 || !(chi[axis] > clo[axis])) {
    node.first = begin;
    node.count = end - begin;
    nodes_[index] = node;
    return index;
  }
  // Binned surface area heuristic on the three axes: the split that minimises
  // area(left) * count(left) + area(right) * count(right), i.e. the expected work of a query.
  constexpr int kBins = 16;
  struct Bin {
    float lo[3], hi[3];
    uint32_t count = 0;
  };
  auto empty_box = [](float lo[3], float hi[3]) {
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::numeric_limits<float>::max();
      hi[k] = std::numeric_limits<float>::lowest();
    }
  };
  auto area = [](const float lo[3], const float hi[3]) {
    const float x = hi[0] - lo[0], y = hi[1] - lo[1], z = hi[2] - lo[2];
    return x < 0 ? 0.0f : x * y + y * z + z * x;
  };
  float best_cost = std::numeric_limits<float>::max();
  int best_axis = -1, best_bin = 0;
  for (int ax = 0; ax < 3; ++ax) {
    const float extent = chi[ax] - clo[ax];
    if (!(extent > 0)) continue;
    Bin bins[kBins];
    for (auto& b : bins) empty_box(b.lo, b.hi);
    const float scale = kBins / extent;
    for (uint32_t i = begin; i < end; ++i) {
      const int b =
          std::min(kBins - 1, static_cast<int>((centroid[order[i]][ax] - clo[ax]) * scale));
      const auto& box = boxes[order[i]];
      ++bins[b].count;
      for (int k = 0; k < 3; ++k) {
        bins[b].lo[k] = std::min(bins[b].lo[k], box[k]);
        bins[b].hi[k] = std::max(bins[b].hi[k], box[3 + k]);
      }
    }
    // Sweep from the right to get the cost of every right side, then from the left.
    float right_cost[kBins];
    float lo[3], hi[3];
    empty_box(lo, hi);
    uint32_t n = 0;
    for (int b = kBins - 1; b > 0; --b) {
      for (int k = 0; k < 3; ++k) {
        lo[k] = std::min(lo[k], bins[b].lo[k]);
        hi[k] = std::max(hi[k], bins[b].hi[k]);
      }
      n += bins[b].count;
      right_cost[b] = n ? area(lo, hi) * n : 0;
    }
    empty_box(lo, hi);
    n = 0;
    for (int b = 0; b + 1 < kBins; ++b) {
      for (int k = 0; k < 3; ++k) {
        lo[k] = std::min(lo[k], bins[b].lo[k]);
        hi[k] = std::max(hi[k], bins[b].hi[k]);
      }
      n += bins[b].count;
      if (n == 0 || n == end - begin) continue;
      const float cost = area(lo, hi) * n + right_cost[b + 1];
      if (cost < best_cost) {
        best_cost = cost;
        best_axis = ax;
        best_bin = b;
      }
    }
  }
  uint32_t mid = begin + (end - begin) / 2;
  if (best_axis >= 0) {
    const float scale = kBins / (chi[best_axis] - clo[best_axis]);
    const float lo_axis = clo[best_axis];
    auto it = std::partition(order.begin() + begin, order.begin() + end, [&](uint32_t x) {
      return std::min(kBins - 1, static_cast<int>((centroid[x][best_axis] - lo_axis) * scale)) <=
             best_bin;
    });
    mid = static_cast<uint32_t>(it - order.begin());
  }
  if (best_axis < 0 || mid == begin || mid == end) {  // no useful split: the median
    mid = begin + (end - begin) / 2;
    std::nth_element(order.begin() + begin, order.begin() + mid, order.begin() + end,
                     [&](uint32_t x, uint32_t y) { return centroid[x][axis] < centroid[y][axis]; });
  }
  build(order, centroid, boxes, begin, mid, depth + 1);  // the left child is index + 1
  node.first = build(order, centroid, boxes, mid, end, depth + 1);
  node.count = 0;
  nodes_[index] = node;
  return index;
}

ClosestHit TriangleBvh::closest(const std::array<float, 3>& point, uint32_t hint) const {
  const float p[3] = {point[0], point[1], point[2]};
  ClosestHit best{std::numeric_limits<float>::infinity(), UINT32_MAX, UINT32_MAX};
  if (hint < tri_.size()) {
    const Tri& t = tri_[hint];
    best = {point_triangle_distance_sq(p, t.a, t.ab, t.ac), t.face, hint};
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
      if (d < best.distance_sq) best = {d, t.face, i};
    }
  }
  return best;
}

}  // namespace qjulia::detail
