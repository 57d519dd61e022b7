// decimate()'s quality method: OpenMesh's Decimater with the quadric, normal-flip and Hausdorff
// modules. Slower than meshoptimizer (4-15x the CPU time on the meshes measured), but it tests the
// link condition itself, so it keeps the topology and reaches face budgets where the guarded
// meshoptimizer path stops early (docs/clean.md).
#include "mesh/decimate_openmesh.h"

#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <OpenMesh/Tools/Decimater/DecimaterT.hh>
#include <OpenMesh/Tools/Decimater/ModHausdorffT.hh>
#include <OpenMesh/Tools/Decimater/ModNormalFlippingT.hh>
#include <OpenMesh/Tools/Decimater/ModQuadricT.hh>
#include <OpenMesh/Tools/Decimater/Observer.hh>
#include <algorithm>

#include "base/mesh_check.h"
#include "qjulia/base/error.h"

namespace qjulia::detail {

namespace {

using OMesh = OpenMesh::TriMesh_ArrayKernelT<>;
using Decimater = OpenMesh::Decimater::DecimaterT<OMesh>;

/// Reports progress and asks the decimater to stop (at a consistent state) on cancellation.
class StopObserver : public OpenMesh::Decimater::Observer {
 public:
  StopObserver(const OpenMeshDecimation& opts, std::size_t expected_collapses)
      : Observer(kInterval), opts_(opts), expected_(std::max<std::size_t>(expected_collapses, 1)) {}

  void notify(std::size_t step) override {
    if (opts_.cancel && opts_.cancel->requested()) stop_ = true;
    if (!stop_ && opts_.progress && !opts_.progress(std::min(1.0, double(step) / expected_)))
      stop_ = true;
  }
  bool abort() const override { return stop_; }
  bool stopped() const { return stop_; }

 private:
  static constexpr std::size_t kInterval = 4096;  // collapses between checks (a few ms)
  const OpenMeshDecimation& opts_;
  const std::size_t expected_;
  bool stop_ = false;
};

/// The faces OpenMesh does not get: a repeated index, a vertex that is non-manifold or
/// misoriented in the input, or a pinned vertex.
std::vector<uint8_t> frozen_faces(const TriMesh& mesh, const std::vector<uint8_t>* pinned) {
  std::vector<uint8_t> hot(mesh.positions.size(), 0);
  for (uint32_t v : check_topology(mesh, /*allow_boundary=*/true).bad_vertices) hot[v] = 1;
  if (pinned && !pinned->empty())
    for (std::size_t v = 0; v < hot.size(); ++v) hot[v] |= (*pinned)[v];
  std::vector<uint8_t> frozen(mesh.triangles.size(), 0);
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
    const auto& t = mesh.triangles[f];
    frozen[f] = t[0] == t[1] || t[1] == t[2] || t[0] == t[2] || hot[t[0]] || hot[t[1]] || hot[t[2]];
  }
  return frozen;
}

}  // namespace

std::vector<std::array<uint32_t, 3>> decimate_openmesh(const TriMesh& mesh,
                                                       const OpenMeshDecimation& opts) {
  throw_if_cancelled(opts.cancel);
  std::vector<uint8_t> frozen = frozen_faces(mesh, opts.pinned);
  OMesh om;
  om.reserve(mesh.positions.size(), 3 * mesh.triangles.size() / 2, mesh.triangles.size());
  for (const auto& p : mesh.positions) om.add_vertex(OMesh::Point(p[0], p[1], p[2]));
  std::vector<std::array<uint32_t, 3>> kept;  // the frozen faces, as they are
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
    const auto& t = mesh.triangles[f];
    if (!frozen[f] && om.add_face(OMesh::VertexHandle(int(t[0])), OMesh::VertexHandle(int(t[1])),
                                  OMesh::VertexHandle(int(t[2])))
                          .is_valid())
      continue;
    frozen[f] = 1;
    kept.push_back(t);
  }
  // Lock the vertices of the frozen faces: the rim of every hole survives exactly.
  om.request_vertex_status();
  om.request_edge_status();
  om.request_face_status();
  for (const auto& t : kept)
    for (uint32_t v : t) om.status(OMesh::VertexHandle(int(v))).set_locked(true);
  om.request_face_normals();
  om.update_face_normals();
  throw_if_cancelled(opts.cancel);

  Decimater decimater(om);
  OpenMesh::Decimater::ModQuadricT<OMesh>::Handle quadric;
  OpenMesh::Decimater::ModNormalFlippingT<OMesh>::Handle flip;
  OpenMesh::Decimater::ModHausdorffT<OMesh>::Handle hausdorff;
  decimater.add(quadric);
  decimater.module(quadric).unset_max_err();  // the priority only
  decimater.add(flip);
  decimater.module(flip).set_max_normal_deviation(opts.max_normal_deviation);
  if (opts.tolerance > 0) {
    decimater.add(hausdorff);
    decimater.module(hausdorff).set_tolerance(static_cast<float>(opts.tolerance));
  }
  decimater.initialize();
  const std::size_t om_faces = om.n_faces();
  const std::size_t target =
      opts.target_faces > kept.size() ? opts.target_faces - kept.size() : std::size_t(0);
  StopObserver observer(opts, om_faces > target ? (om_faces - target) / 2 : 0);
  decimater.set_observer(&observer);
  if (opts.target_faces > 0)
    decimater.decimate_to_faces(0, std::max<std::size_t>(target, 1));
  else
    decimater.decimate(0);
  decimater.set_observer(nullptr);
  if (observer.stopped()) throw Cancelled();

  std::vector<std::array<uint32_t, 3>> out = std::move(kept);
  out.reserve(out.size() + om_faces);
  for (const auto f : om.faces()) {  // vertex handles are input indices
    if (om.status(f).deleted()) continue;
    std::array<uint32_t, 3> t;
    int k = 0;
    for (const auto v : om.fv_range(f)) t[k++] = static_cast<uint32_t>(v.idx());
    out.push_back(t);
  }
  return out;
}

}  // namespace qjulia::detail
