// compare: measures of two surfaces and their two-sided Hausdorff distance, estimated from dense
// surface samples (every vertex plus area-proportional random points) against a BVH of the
// other surface. Exact point-to-triangle distances; only the sampling of the source surface is
// approximate, so each directed maximum is a lower bound within the sample spacing.
#include "qjulia/mesh/compare.h"

#include <tbb/parallel_invoke.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>

#include "base/bvh.h"
#include "base/geometry.h"
#include "base/hash.h"
#include "base/mesh_json.h"
#include "base/stage_progress.h"
#include "base/weld.h"
#include "qjulia/base/error.h"
#include "qjulia/base/validate.h"

namespace qjulia {

namespace {

using Point = std::array<float, 3>;

// A counter-based generator (splitmix64), so sample i is the same whatever thread makes it.
inline double unit(std::uint64_t x) {
  return (detail::splitmix64(x) >> 11) * (1.0 / 9007199254740992.0);
}

bool valid_face(const TriMesh& m, const std::array<uint32_t, 3>& t) {
  const std::size_t n = m.positions.size();
  return t[0] < n && t[1] < n && t[2] < n;
}

// The surface samples of `m`: its referenced vertices first (their indices in `vertex_of`),
// then random points up to `total_samples`, stratified along the cumulative area so every face gets
// its share (area * density, rounded randomly). Made on demand, batch by batch: sample i is the
// same whenever and on whichever thread it is made, and the samples are never all in memory.
class Samples {
 public:
  Samples() = default;
  Samples(const TriMesh& m, std::size_t total_samples, std::uint64_t seed) : m_(&m), seed_(seed) {
    std::vector<char> used(m.positions.size(), 0);
    for (const auto& t : m.triangles)
      if (valid_face(m, t)) used[t[0]] = used[t[1]] = used[t[2]] = 1;
    for (uint32_t v = 0; v < used.size(); ++v)
      if (used[v]) vertex_of.push_back(v);
    const std::size_t nv = vertex_of.size();
    cumulative_.assign(m.triangles.size() + 1, 0.0);
    for (std::size_t f = 0; f < m.triangles.size(); ++f) {
      const auto& t = m.triangles[f];
      const double area = valid_face(m, t)
                              ? detail::triangle_area(detail::to_vec3d(m.positions[t[0]]),
                                                      detail::to_vec3d(m.positions[t[1]]),
                                                      detail::to_vec3d(m.positions[t[2]]))
                              : 0.0;
      cumulative_[f + 1] = cumulative_[f] + area;
    }
    total_ = cumulative_.back();
    // The vertices count towards the total; a mesh with more vertices than that is sampled by
    // its vertices alone (they are then denser than the requested samples).
    count_ = total_samples > nv ? total_samples - nv : 0;
    if (!(total_ > 0)) count_ = 0;
    if (count_ == 0) std::vector<double>().swap(cumulative_);  // the vertices alone
  }

  std::vector<uint32_t> vertex_of;  // the vertex of sample i for i < vertex_of.size()

  std::size_t size() const { return vertex_of.size() + count_; }

  // Samples [begin, end) into `out`.
  void make(std::size_t begin, std::size_t end, Point* out) const {
    const TriMesh& m = *m_;
    const std::size_t nv = vertex_of.size();
    for (std::size_t i = begin; i != end; ++i, ++out) {
      if (i < nv) {
        *out = m.positions[vertex_of[i]];
        continue;
      }
      const std::size_t j = i - nv;
      const std::uint64_t key = seed_ * 0x100000001b3ULL + 3 * j;
      const double target = (j + unit(key)) / count_ * total_;
      auto it = std::upper_bound(cumulative_.begin() + 1, cumulative_.end(), target);
      std::size_t f = std::min<std::size_t>(it - cumulative_.begin() - 1, m.triangles.size() - 1);
      while (f > 0 && !(cumulative_[f + 1] > cumulative_[f])) --f;
      const auto& t = m.triangles[f];
      // Uniform on the triangle: the square-root warp of two uniforms.
      const double r1 = std::sqrt(unit(key + 1)), r2 = unit(key + 2);
      const double wa = 1 - r1, wb = r1 * (1 - r2), wc = r1 * r2;
      const auto &a = m.positions[t[0]], &b = m.positions[t[1]], &c = m.positions[t[2]];
      for (int k = 0; k < 3; ++k) (*out)[k] = static_cast<float>(wa * a[k] + wb * b[k] + wc * c[k]);
    }
  }

 private:
  const TriMesh* m_ = nullptr;
  std::uint64_t seed_ = 0;
  std::vector<double> cumulative_;
  double total_ = 0;
  std::size_t count_ = 0;
};

// The distances of the samples of `from` to the surface in `tree`, summed in sample order as they
// come; `first` (when given) receives the distances of the first samples (its size of them).
DirectedDistance directed(const Samples& from, const detail::TriangleBvh& tree,
                          const CancelToken* cancel, const std::function<void(double)>& step,
                          std::vector<float>* first = nullptr) {
  DirectedDistance out;
  double sum = 0, sum_sq = 0, mx = 0;
  tree.distances(
      from.size(),
      [&](std::size_t begin, std::size_t end, Point* points) { from.make(begin, end, points); },
      [&](std::size_t begin, const float* d, std::size_t n) {
        for (std::size_t i = 0; i < n; ++i) {
          const float x = d[i];
          sum += x;
          sum_sq += static_cast<double>(x) * x;
          mx = std::max(mx, static_cast<double>(x));
        }
        if (first && begin < first->size())
          std::copy(d, d + std::min(n, first->size() - begin), first->begin() + begin);
      },
      cancel, step);
  out.samples = from.size();
  out.max = mx;
  if (out.samples > 0) {
    out.mean = sum / out.samples;
    out.rms = std::sqrt(sum_sq / out.samples);
  }
  return out;
}

// The shared measures (the keys of --stats), the genus summary and every component.
nlohmann::json measure_json(const MeshMeasure& m) {
  nlohmann::json j = detail::measure_to_json(m);
  nlohmann::json comps = nlohmann::json::array();
  for (const auto& c : m.components)
    comps.push_back({{"faces", c.faces},
                     {"volume", c.volume},
                     {"area", c.area},
                     {"closed", c.closed},
                     {"euler", c.euler},
                     {"genus", c.genus}});
  j["genus_summary"] = genus_summary(m);
  j["component_measures"] = std::move(comps);
  return j;
}

nlohmann::json directed_json(const DirectedDistance& d) {
  return {{"max", d.max}, {"mean", d.mean}, {"rms", d.rms}, {"samples", d.samples}};
}

// The measures of `m` with its vertices at one position merged (triangles that then repeat a
// vertex have no area and go); `welded`: how many vertices were merged into another.
MeshMeasure measure_welded(const TriMesh& m, const CancelToken* cancel, std::size_t& welded) {
  std::vector<std::uint32_t> index(m.positions.size());
  const std::size_t distinct =
      detail::number_positions(m.positions.data(), m.positions.size(), index.data());
  welded = m.positions.size() - distinct;
  if (welded == 0) return measure(m, cancel);
  TriMesh w;
  w.positions.resize(distinct);
  detail::first_positions(m.positions.data(), m.positions.size(), index.data(), w.positions.data());
  w.triangles.reserve(m.triangles.size());
  for (const auto& t : m.triangles) {
    const std::array<std::uint32_t, 3> u = {index[t[0]], index[t[1]], index[t[2]]};
    if (u[0] != u[1] && u[1] != u[2] && u[0] != u[2]) w.triangles.push_back(u);
  }
  return measure(w, cancel);
}

}  // namespace

CompareResult compare(const TriMesh& a, const TriMesh& b, const CompareOptions& opts) {
  validate_mesh(a, "compare: the first surface (a)", {/*faces=*/true});
  validate_mesh(b, "compare: the second surface (b)", {/*faces=*/true});
  if (opts.samples > kMostCompareSamples)
    throw InvalidInput("compare: samples must be at most " + std::to_string(kMostCompareSamples) +
                       " per surface, not " + std::to_string(opts.samples));
  CompareResult result;
  std::unique_ptr<detail::TriangleBvh> bvh_a, bvh_b;
  Samples sa, sb;
  tbb::parallel_invoke(
      [&] { result.a = measure_welded(a, opts.cancel, result.a_welded); },
      [&] { result.b = measure_welded(b, opts.cancel, result.b_welded); },
      [&] { bvh_a = std::make_unique<detail::TriangleBvh>(a.positions, a.triangles); },
      [&] { bvh_b = std::make_unique<detail::TriangleBvh>(b.positions, b.triangles); },
      [&] { sa = Samples(a, opts.samples, opts.seed); },
      [&] { sb = Samples(b, opts.samples, opts.seed + 1); });
  detail::report_progress(opts.progress, opts.cancel, 0.1);

  const double total = static_cast<double>(sa.size() + sb.size());
  auto stepper = [&](double offset, double size) {
    return [&opts, offset, size, total](double f) {
      detail::report_progress(opts.progress, nullptr, 0.1 + 0.9 * (offset + f * size) / total);
    };
  };
  const double na = static_cast<double>(sa.size());
  std::vector<float> da(sa.vertex_of.size());  // the distances of a's vertices
  result.a_to_b = directed(sa, *bvh_b, opts.cancel, stepper(0, na), &da);
  result.b_to_a = directed(sb, *bvh_a, opts.cancel, stepper(na, total - na));
  result.hausdorff = std::max(result.a_to_b.max, result.b_to_a.max);

  // Per vertex of a; unreferenced vertices get their distance too (they are not samples).
  result.a_vertex_distance.assign(a.positions.size(), 0.0f);
  for (std::size_t i = 0; i < sa.vertex_of.size(); ++i)
    result.a_vertex_distance[sa.vertex_of[i]] = da[i];
  for (uint32_t v = 0; v < a.positions.size(); ++v) {
    if (std::binary_search(sa.vertex_of.begin(), sa.vertex_of.end(), v)) continue;
    result.a_vertex_distance[v] = std::sqrt(bvh_b->closest(a.positions[v]).distance_sq);
  }
  detail::report_progress(opts.progress, opts.cancel, 1.0);
  return result;
}

std::vector<std::array<float, 3>> distance_colors(const std::vector<float>& values, double lo,
                                                  double hi) {
  // blue, cyan, green, yellow, red
  static const float kStops[5][3] = {{0.05f, 0.15f, 0.9f},
                                     {0.0f, 0.8f, 0.9f},
                                     {0.1f, 0.85f, 0.1f},
                                     {0.95f, 0.9f, 0.05f},
                                     {0.9f, 0.05f, 0.05f}};
  std::vector<std::array<float, 3>> out(values.size());
  const double span = hi > lo ? hi - lo : 1.0;
  for (std::size_t i = 0; i < values.size(); ++i) {
    double t = (values[i] - lo) / span;
    t = std::isfinite(t) ? std::clamp(t, 0.0, 1.0) : 1.0;
    const double x = t * 4;
    const int k = std::min(3, static_cast<int>(x));
    const float w = static_cast<float>(x - k);
    for (int c = 0; c < 3; ++c) out[i][c] = (1 - w) * kStops[k][c] + w * kStops[k + 1][c];
  }
  return out;
}

std::string genus_summary(const MeshMeasure& m, std::size_t max_groups) {
  if (m.components.empty()) return "none";
  std::map<long long, std::size_t> genus;
  std::size_t open = 0;
  for (const auto& c : m.components) {
    if (c.closed)
      ++genus[c.genus];
    else
      ++open;
  }
  std::vector<std::pair<long long, std::size_t>> groups(genus.begin(), genus.end());
  std::size_t more = 0;
  if (max_groups > 0 && groups.size() > max_groups) {
    // The most frequent genus values, then listed by genus.
    std::stable_sort(groups.begin(), groups.end(),
                     [](const auto& x, const auto& y) { return x.second > y.second; });
    more = groups.size() - max_groups;
    groups.resize(max_groups);
    std::sort(groups.begin(), groups.end());
  }
  std::ostringstream out;
  bool first = true;
  for (const auto& [g, n] : groups) {
    out << (first ? "genus " : ", ") << g << " x" << n;
    first = false;
  }
  if (more) out << ", +" << more << " more";
  if (open) out << (first ? "" : "; ") << open << " open";
  return out.str();
}

std::string compare_legend_json(double lo, double hi, const std::string& name_a,
                                const std::string& name_b) {
  const nlohmann::json j = {
      {"compare", {{"legend_min", lo}, {"legend_max", hi}, {"a", name_a}, {"b", name_b}}}};
  return j.dump(2) + "\n";
}

std::string compare_to_json(const CompareResult& r, const std::string& name_a,
                            const std::string& name_b) {
  nlohmann::json j = {{"a_name", name_a},
                      {"b_name", name_b},
                      {"a", measure_json(r.a)},
                      {"b", measure_json(r.b)},
                      {"a_to_b", directed_json(r.a_to_b)},
                      {"b_to_a", directed_json(r.b_to_a)},
                      {"hausdorff", r.hausdorff},
                      {"a_welded_vertices", r.a_welded},
                      {"b_welded_vertices", r.b_welded}};
  return j.dump(2) + "\n";
}

}  // namespace qjulia
