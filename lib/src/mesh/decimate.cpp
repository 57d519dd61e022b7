// Decimation: edge collapses by quadric error that keep the topology (mesh/collapse.h), run in
// parallel on spatial chunks, plus a sample-based Hausdorff check.
//
// The collapses test the link condition and reject face flips, so a closed manifold stays closed
// and manifold and keeps its components and Euler characteristic. The result is still verified;
// where it is not manifold (an input the conditions do not cover), the input faces around the
// offending vertices are frozen (their vertices are never removed) and the pass is made again,
// the frozen region growing until the result is manifold.
//
// One pass is serial. Large meshes are therefore cut into chunks along a Morton curve,
// simplified in parallel with the vertices around their cuts locked; a second, small pass over
// the joined result removes the full-resolution seams. The chunk count follows from the face
// count alone, so the result depends only on the input and the options, never on the threads.
//
// Under a face budget the result must keep the input's components and Euler characteristic; if
// a pass does not all the same, the mesh is decimated in stages from the last result kept
// (decimate()).
#include "qjulia/mesh/decimate.h"

#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <cmath>
#include <iterator>
#include <memory>
#include <string>
#include <unordered_map>

#include "base/geometry.h"
#include "base/mesh_check.h"
#include "base/stage_progress.h"
#include "mesh/collapse.h"
#include "mesh/decimate_openmesh.h"
#include "mesh/hausdorff.h"
#include "qjulia/base/error.h"
#include "qjulia/base/validate.h"

namespace qjulia {

namespace {

constexpr std::size_t kChunkFaces = 150'000;  // faces per chunk; below 2x this, one pass
constexpr std::size_t kMinChunks = 4;         // chunks of a mesh of 2-4 times kChunkFaces
constexpr int kMaxAttempts = 12;
// Without an error bound, the collapses' quadric error is bounded by this fraction of the
// bounding box's diagonal (half of it in each of the two stages).
constexpr double kShapeBound = 0.02;

/// The bounding box of mesh's vertices: its lower and upper corners.
std::array<detail::Vec3d, 2> bounds(const TriMesh& mesh) {
  detail::Vec3d lo{{1e300, 1e300, 1e300}}, hi{{-1e300, -1e300, -1e300}};
  for (const auto& p : mesh.positions)
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], double(p[k]));
      hi[k] = std::max(hi[k], double(p[k]));
    }
  return {lo, hi};
}

/// The topology a decimation must keep: vertex-connected components and the Euler
/// characteristic V - E + F (of the referenced vertices).
struct Shape {
  std::size_t components = 0;
  long long euler = 0;
  bool operator==(const Shape& o) const { return components == o.components && euler == o.euler; }
};

Shape shape_of(const TriMesh& mesh, std::size_t edges) {
  std::vector<uint8_t> used(mesh.positions.size(), 0);
  for (const auto& t : mesh.triangles)
    for (uint32_t v : t) used[v] = 1;
  const auto vertices = static_cast<long long>(std::count(used.begin(), used.end(), 1));
  std::vector<uint32_t> face_component;
  Shape s;
  s.components = detail::face_components(mesh, face_component);
  s.euler = vertices - static_cast<long long>(edges) + static_cast<long long>(mesh.face_count());
  return s;
}

/// One pass of edge collapses that never removes the vertices marked in `locked` (so the faces
/// holding only such vertices stay as they are); returns the triangles (indexing mesh.positions)
/// with fins removed.
std::vector<std::array<uint32_t, 3>> simplify_once(const TriMesh& mesh,
                                                   const std::vector<uint8_t>& locked,
                                                   std::size_t target_faces, double abs_error,
                                                   const CancelToken* cancel) {
  detail::CollapseOptions o;
  o.target_faces = target_faces;
  o.max_error = abs_error;
  o.locked = &locked;
  o.cancel = cancel;
  TriMesh kept;
  kept.triangles = detail::collapse_edges(mesh, o);
  detail::drop_repeated_and_fins(kept);
  return std::move(kept.triangles);
}

/// Simplifies `mesh` (positions and triangles only) to `target_faces` / `abs_error`, repeating
/// with a growing frozen region until the result is manifold (boundary edges, e.g. at chunk
/// cuts, are locked and allowed). Returns triangles indexing mesh.positions.
std::vector<std::array<uint32_t, 3>> simplify_manifold(const TriMesh& mesh,
                                                       std::size_t target_faces, double abs_error,
                                                       const CancelToken* cancel, bool* ok,
                                                       const std::vector<uint32_t>& pinned = {}) {
  std::vector<uint8_t> frozen(mesh.triangles.size(), 0);
  std::vector<uint8_t> locked(mesh.positions.size(), 0);  // the frozen faces' vertices
  std::unique_ptr<detail::VertexFaces> stars;
  // Freezes the faces around `seeds` and `rings` rings beyond.
  auto freeze = [&](std::vector<uint32_t> ring, int rings) {
    if (!stars) stars = std::make_unique<detail::VertexFaces>(mesh);
    for (int grow = 0; grow < rings; ++grow) {
      std::vector<uint32_t> next;
      for (uint32_t v : ring)
        for (uint32_t k = stars->offsets[v]; k < stars->offsets[v + 1]; ++k) {
          const uint32_t f = stars->faces[k];
          if (frozen[f]) continue;
          frozen[f] = 1;
          for (uint32_t w : mesh.triangles[f])
            if (!locked[w]) {
              locked[w] = 1;
              next.push_back(w);
            }
        }
      ring.swap(next);
    }
  };
  // Vertices already non-manifold in the input stay as they are: their faces are frozen from the
  // start and they are not counted as new defects. So are the faces around a chunk's cut: then
  // no two chunks can both join the same pair of cut vertices (a non-manifold edge that neither
  // chunk would see), as the vertices a chunk may connect belong to it alone.
  const auto input_topology = detail::check_topology(mesh, /*allow_boundary=*/true);
  const std::vector<uint32_t>& input_bad = input_topology.bad_vertices;
  std::vector<uint32_t> seeds = input_bad;
  seeds.insert(seeds.end(), input_topology.boundary_vertices.begin(),
               input_topology.boundary_vertices.end());
  if (!seeds.empty()) freeze(seeds, 1);
  // Vertices of faces that intersected in an earlier result: two rings kept as they are.
  if (!pinned.empty()) freeze(pinned, 2);
  TriMesh out;
  for (int attempt = 0; attempt < kMaxAttempts; ++attempt) {
    throw_if_cancelled(cancel);
    out.triangles = simplify_once(mesh, locked, target_faces, abs_error, cancel);
    throw_if_cancelled(cancel);
    out.positions.clear();  // check_topology only needs the vertex count
    out.positions.resize(mesh.positions.size());
    const auto topo = detail::check_topology(out, /*allow_boundary=*/true);
    std::vector<uint32_t> fresh;
    std::set_difference(topo.bad_vertices.begin(), topo.bad_vertices.end(), input_bad.begin(),
                        input_bad.end(), std::back_inserter(fresh));
    if (fresh.empty()) {
      *ok = true;
      return std::move(out.triangles);
    }
    // Freeze the input faces around the new defects: two rings, one more each round.
    freeze(fresh, 2 + attempt);
  }
  // Give up simplifying: return the input, which is manifold.
  *ok = false;
  return mesh.triangles;
}

/// Stage 1 for large meshes: compact chunks of faces (consecutive along a Morton curve of
/// their centroids), simplified in parallel with their cut edges locked. Returns triangles
/// indexing mesh.positions.
std::vector<std::array<uint32_t, 3>> simplify_chunks(const TriMesh& mesh, double ratio,
                                                     double abs_error,
                                                     const std::vector<uint8_t>& pinned,
                                                     const CancelToken* cancel) {
  const std::size_t nf = mesh.triangles.size();
  const std::size_t chunks = std::max(kMinChunks, (nf + kChunkFaces - 1) / kChunkFaces);
  const auto box = bounds(mesh);
  const detail::Vec3d &lo = box[0], &hi = box[1];
  const double extent = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2], 1e-30});
  const double to_grid = double((1 << 21) - 1) / (3.0 * extent);
  std::vector<std::pair<uint64_t, uint32_t>> order(nf);
  tbb::parallel_for(std::size_t(0), nf, [&](std::size_t f) {
    const auto& t = mesh.triangles[f];
    uint32_t c[3];
    for (int k = 0; k < 3; ++k)
      c[k] = static_cast<uint32_t>((double(mesh.positions[t[0]][k]) + mesh.positions[t[1]][k] +
                                    mesh.positions[t[2]][k] - 3 * lo[k]) *
                                   to_grid);
    order[f] = {detail::morton_code(c[0], c[1], c[2]), static_cast<uint32_t>(f)};
  });
  std::vector<std::size_t> cut(chunks + 1);
  for (std::size_t c = 0; c <= chunks; ++c) cut[c] = nf * c / chunks;
  tbb::parallel_sort(order.begin(), order.end());
  throw_if_cancelled(cancel);
  std::vector<std::vector<std::array<uint32_t, 3>>> results(chunks);
  tbb::parallel_for(std::size_t(0), chunks, [&](std::size_t c) {
    throw_if_cancelled(cancel);
    // Local mesh with compact vertices.
    TriMesh local;
    std::vector<uint32_t> global, local_pinned;
    std::unordered_map<uint32_t, uint32_t> to_local;
    to_local.reserve((cut[c + 1] - cut[c]) * 3 / 2);
    for (std::size_t i = cut[c]; i < cut[c + 1]; ++i) {
      std::array<uint32_t, 3> t;
      for (int k = 0; k < 3; ++k) {
        const uint32_t v = mesh.triangles[order[i].second][k];
        auto [it, fresh] = to_local.emplace(v, static_cast<uint32_t>(global.size()));
        if (fresh) {
          if (!pinned.empty() && pinned[v]) local_pinned.push_back(it->second);
          global.push_back(v);
          local.positions.push_back(mesh.positions[v]);
        }
        t[k] = it->second;
      }
      local.triangles.push_back(t);
    }
    bool ok = false;
    const auto target = static_cast<std::size_t>(std::ceil(local.triangles.size() * ratio));
    auto tris = simplify_manifold(local, target, abs_error, cancel, &ok, local_pinned);
    for (auto& t : tris)
      for (auto& v : t) v = global[v];
    results[c] = std::move(tris);
  });
  std::vector<std::array<uint32_t, 3>> all;
  for (auto& r : results) all.insert(all.end(), r.begin(), r.end());
  return all;
}

/// A simplified mesh with compact vertices, and the input vertex of each of its vertices.
struct Simplified {
  TriMesh mesh;
  std::vector<uint32_t> to_input;
};

/// One decimation of `mesh` to the budget and the bound `abs_error`, keeping `pinned` input
/// vertices and their faces. Fast method: stage 1 (chunks, when `use_chunks`) and stage 2 (the
/// whole mesh), each collapse within half of `abs_error` (quadric error); the result is closed and
/// manifold wherever the chunk-wise checks could see. Quality method: OpenMesh with abs_error as
/// its Hausdorff bound.
Simplified simplify_all(const TriMesh& mesh, const DecimateOptions& opts, double abs_error,
                        bool use_chunks, const std::vector<uint8_t>& pinned) {
  const std::size_t nv = mesh.positions.size();
  const std::size_t budget = opts.faces ? static_cast<std::size_t>(*opts.faces) : std::size_t(0);
  Simplified s;
  TriMesh& work = s.mesh;  // positions shared with the input; triangles as simplified so far
  work.positions = mesh.positions;
  work.colors = mesh.colors;
  work.triangles = mesh.triangles;
  s.to_input.resize(nv);
  for (uint32_t i = 0; i < nv; ++i) s.to_input[i] = i;
  auto compact = [&] {
    std::vector<uint32_t> remap;
    detail::compact_vertices(work, &remap);
    std::vector<uint32_t> next(work.positions.size());
    for (std::size_t i = 0; i < remap.size(); ++i)
      if (remap[i] != 0xffffffffu) next[remap[i]] = s.to_input[i];
    s.to_input.swap(next);
  };
  if (opts.method == DecimateMethod::kQuality) {
    detail::OpenMeshDecimation om;
    om.target_faces = budget;
    om.tolerance = opts.max_error ? abs_error : 0.0;
    om.pinned = &pinned;
    om.cancel = opts.cancel;
    om.progress = [&opts](double f) { return !opts.progress || opts.progress(0.4 * f); };
    work.triangles = detail::decimate_openmesh(mesh, om);
    detail::report_progress(opts.progress, opts.cancel, 0.4);
    compact();
    return s;
  }
  // Stage 1 stops at 1.5 times the budget so that stage 2 has room to dissolve the seams (none
  // when that is the whole mesh).
  const double ratio = opts.faces ? 1.5 * budget / mesh.face_count() : 0.0;
  if (use_chunks && ratio < 1.0)
    work.triangles = simplify_chunks(mesh, ratio, 0.5 * abs_error, pinned, opts.cancel);
  detail::report_progress(opts.progress, opts.cancel, 0.4);
  // Stage 2 (or the only stage): the whole mesh.
  if (!opts.faces || work.face_count() > budget) {
    // Compact first so the per-vertex work follows the smaller mesh.
    compact();
    std::vector<uint32_t> work_pinned;
    if (!pinned.empty())
      for (uint32_t i = 0; i < s.to_input.size(); ++i)
        if (pinned[s.to_input[i]]) work_pinned.push_back(i);
    bool ok = false;
    work.triangles =
        simplify_manifold(work, budget, 0.5 * abs_error, opts.cancel, &ok, work_pinned);
  }
  compact();
  return s;
}

/// Pins (in `pinned`, per input vertex) the input vertices of the faces of `s` that intersect
/// others; returns true when a vertex was not pinned before. Sets rep.self_intersections.
bool pin_self_intersections(const Simplified& s, std::vector<uint8_t>& pinned,
                            DecimateReport& rep) {
  const auto pairs = detail::self_intersecting_face_pairs(s.mesh);
  rep.self_intersections = pairs.size();
  bool fresh = false;
  for (const auto& [a, b] : pairs)
    for (uint32_t f : {a, b})
      for (uint32_t v : s.mesh.triangles[f])
        if (!pinned[s.to_input[v]]) {
          pinned[s.to_input[v]] = 1;
          fresh = true;
        }
  return fresh;
}

/// The report of a mesh that is returned as it is.
DecimateReport unchanged_report(const TriMesh& mesh) {
  DecimateReport rep;
  rep.faces_before = rep.faces_after = mesh.face_count();
  const auto topo = detail::check_topology(mesh);
  rep.closed = topo.closed();
  rep.manifold = topo.manifold() && topo.oriented();
  return rep;
}

/// A decimation and what it did.
struct Outcome {
  Simplified s;
  DecimateReport rep;
  Shape shape;
};

/// One decimation of `mesh` under `opts`: simplified, checked (closed, manifold; the Hausdorff
/// distance when opts.max_error bounds it) and redone with a tighter bound or pinned vertices
/// while a check asks for it; its shape measured.
Outcome decimate_once(const TriMesh& mesh, const DecimateOptions& opts,
                      detail::Hausdorff& hausdorff) {
  const std::size_t nv = mesh.positions.size();
  const std::size_t budget = opts.faces ? static_cast<std::size_t>(*opts.faces) : std::size_t(0);
  // The collapses' error is the quadric (distance to planes) error, not the Hausdorff distance:
  // close to it on smooth surfaces, smaller on bumpy ones. The first round uses the
  // bound (half per stage); when the measured distance exceeds it, the bound is scaled by
  // 0.85 * max_error / measured and the work redone.
  Outcome o;
  DecimateReport& rep = o.rep;
  rep.faces_before = mesh.face_count();
  double abs_error = opts.max_error ? *opts.max_error : 1e30;
  // A face budget alone: the collapses keep the topology, and this bound keeps the shape where
  // the budget is below what the surface can hold.
  if (!opts.max_error) {
    const auto box = bounds(mesh);
    abs_error = kShapeBound * detail::length(box[1] - box[0]);
  }
  Simplified& best = o.s;
  bool use_chunks = opts.method == DecimateMethod::kFast && mesh.face_count() >= 2 * kChunkFaces;
  std::vector<uint8_t> pinned;  // input vertices kept with their stars (self-intersections)
  int intersection_rounds = 0;
  detail::TopologyCheck topo;
  for (int attempt = 0; attempt < 10; ++attempt) {
    best = simplify_all(mesh, opts, abs_error, use_chunks, pinned);
    // Safety net: a defect that the chunk-wise checks could not see means redoing it in one piece
    // (unless the input had the defect already).
    topo = detail::check_topology(best.mesh);
    rep.closed = topo.closed();
    rep.manifold = topo.manifold() && topo.oriented();
    if (use_chunks && !(rep.closed && rep.manifold)) {
      const auto in = detail::check_topology(mesh);
      if (in.closed() && in.manifold() && in.oriented()) {
        use_chunks = false;
        continue;
      }
    }
    detail::report_progress(opts.progress, opts.cancel, 0.7);
    // Without a bound, the distance of the result the caller keeps is measured by the caller.
    if (opts.max_error) rep.hausdorff = hausdorff.to(best.mesh).distance();
    if (opts.max_error && rep.hausdorff > *opts.max_error) {
      abs_error *= 0.85 * (*opts.max_error / rep.hausdorff);
      continue;
    }
    // Pin the input vertices of intersecting faces and redo; stop when every intersecting face
    // is already pinned (then the input had the intersection) or after three rounds.
    if (opts.avoid_self_intersections) {
      if (pinned.empty()) pinned.assign(nv, 0);
      if (pin_self_intersections(best, pinned, rep) && intersection_rounds++ < 3) continue;
    }
    break;
  }
  // Input normals describe the fine surface; the caller recomputes them for the coarse one.
  best.mesh.normals.clear();
  rep.faces_after = best.mesh.face_count();
  rep.target_reached = (!opts.faces || rep.faces_after <= budget) &&
                       (!opts.max_error || rep.hausdorff <= *opts.max_error);
  o.shape = shape_of(best.mesh, topo.edges);
  return o;
}

/// `progress` for the part [from, to] of the whole stage.
ProgressFn sub_progress(const ProgressFn& progress, double from, double to) {
  if (!progress) return {};
  return [progress, from, to](double f) { return progress(from + (to - from) * f); };
}

}  // namespace

TriMesh decimate(const TriMesh& mesh, const DecimateOptions& opts, DecimateReport* report) {
  if (!opts.faces && !opts.max_error) throw InvalidInput("decimate: set faces and/or max_error");
  if (opts.faces && *opts.faces < 1)
    throw InvalidInput("decimate: faces must be >= 1, got " + std::to_string(*opts.faces));
  if (opts.max_error && !(*opts.max_error > 0 && std::isfinite(*opts.max_error)))
    throw InvalidInput("decimate: max_error must be a positive number, got " +
                       std::to_string(*opts.max_error));
  validate_mesh(mesh, "decimate");

  const std::size_t budget = opts.faces ? static_cast<std::size_t>(*opts.faces) : std::size_t(0);
  if (mesh.triangles.empty() || (opts.faces && budget >= mesh.face_count())) {
    if (report) *report = unchanged_report(mesh);
    return mesh;
  }
  detail::report_progress(opts.progress, opts.cancel, 0.0);
  detail::HausdorffOptions hopts;
  hopts.cancel = opts.cancel;
  detail::Hausdorff hausdorff(mesh, hopts);  // keeps the input's BVH between attempts

  // The fast method's collapses keep the topology by the link condition, and without max_error
  // its shape bound (kShapeBound) stops them where a budget is below what the surface can hold
  // (meshoptimizer's collapses, used before, closed tunnels and dropped components there: a
  // genus-12 surface asked for 20 faces became a tetrahedron). A result is kept when it has the
  // components and the Euler characteristic of the input, reached its budget or not (the report
  // says which). Should a pass change them all the same (an input the checks do not cover), the
  // mesh is decimated in stages instead, each from the last one kept, 30% fewer faces a stage
  // (10% after a stage fails, at most eight such), until the budget or until a stage of 10%
  // fails or removes nothing.
  const bool guard = opts.faces && opts.method == DecimateMethod::kFast;
  Outcome out = decimate_once(mesh, opts, hausdorff);  // reports progress up to 0.7
  if (guard) {
    const Shape input = shape_of(mesh, detail::check_topology(mesh).edges);
    if (!(out.shape == input)) {
      out = Outcome();              // its memory, freed
      std::optional<Outcome> last;  // the last stage kept; none: the input
      double step = 0.7;
      int fine_stages = 0;
      const double span = std::log(double(mesh.face_count()) / double(budget));
      // A stage that fails starts again from the same mesh: the bar does not go back. (At most
      // 32 stages: 30% fewer faces a stage reach 1e-5 of the input.)
      auto high = std::make_shared<double>(0.7);
      ProgressFn forward;
      if (opts.progress)
        forward = [high, progress = opts.progress](double f) {
          *high = std::max(*high, f);
          return progress(*high);
        };
      for (int stage = 0; stage < 32; ++stage) {
        if (step > 0.7 && fine_stages++ == 8) break;
        const TriMesh& from = last ? last->s.mesh : mesh;
        const auto asked = std::max(
            budget, static_cast<std::size_t>(std::floor(double(from.face_count()) * step)));
        DecimateOptions o = opts;
        o.faces = static_cast<long long>(asked);
        auto done = [&](std::size_t faces) {
          return 0.7 + 0.3 * std::log(double(mesh.face_count()) / double(faces)) / span;
        };
        o.progress = sub_progress(forward, done(from.face_count()), done(asked));
        Outcome tried = decimate_once(from, o, hausdorff);
        if (tried.shape == input && tried.rep.faces_after < from.face_count()) {
          last = std::move(tried);
          if (last->rep.faces_after <= budget) break;
        } else if (step < 0.9) {
          step = 0.9;
        } else {
          break;
        }
      }
      if (last) {
        out = std::move(*last);
      } else {  // no stage kept the shape: the input
        out.s.mesh = mesh;
        out.s.mesh.normals.clear();
        out.rep = unchanged_report(mesh);
      }
      out.rep.faces_before = mesh.face_count();  // a stage's report counts from its own input
      out.rep.target_reached = out.rep.faces_after <= budget &&
                               (!opts.max_error || out.rep.hausdorff <= *opts.max_error);
    }
  }
  if (!opts.max_error && out.rep.faces_after != mesh.face_count())
    out.rep.hausdorff = hausdorff.to(out.s.mesh).distance();
  detail::report_progress(opts.progress, opts.cancel, 1.0);
  if (report) *report = out.rep;
  return std::move(out.s.mesh);
}

}  // namespace qjulia
