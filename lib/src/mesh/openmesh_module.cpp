// libqjulia_openmesh.so: OpenMesh's Decimater for decimate()'s quality method (see
// openmesh_module.h). The only file that includes OpenMesh headers; it uses nothing of libqjulia.
#include "mesh/openmesh_module.h"

#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <OpenMesh/Tools/Decimater/DecimaterT.hh>
#include <OpenMesh/Tools/Decimater/ModHausdorffT.hh>
#include <OpenMesh/Tools/Decimater/ModNormalFlippingT.hh>
#include <OpenMesh/Tools/Decimater/ModQuadricT.hh>
#include <OpenMesh/Tools/Decimater/Observer.hh>
#include <algorithm>
#include <exception>
#include <new>

namespace qjulia::detail {
namespace {

using OMesh = OpenMesh::TriMesh_ArrayKernelT<>;
using Decimater = OpenMesh::Decimater::DecimaterT<OMesh>;

/// Reports progress and asks the decimater to stop (at a consistent state) when told to.
class StopObserver : public OpenMesh::Decimater::Observer {
 public:
  StopObserver(const OpenMeshJob& job, std::size_t expected_collapses)
      : Observer(kInterval), job_(job), expected_(std::max<std::size_t>(expected_collapses, 1)) {}

  void notify(std::size_t step) override {
    if (!stop_ && job_.keep_going &&
        !job_.keep_going(std::min(1.0, double(step) / expected_), job_.token))
      stop_ = true;
  }
  bool abort() const override { return stop_; }
  bool stopped() const { return stop_; }

 private:
  static constexpr std::size_t kInterval = 4096;  // collapses between checks (a few ms)
  const OpenMeshJob& job_;
  const std::size_t expected_;
  bool stop_ = false;
};

void run(const OpenMeshJob& job, std::vector<std::array<std::uint32_t, 3>>& out, bool& stopped) {
  OMesh om;
  om.reserve(job.vertices, 3 * job.faces / 2, job.faces);
  for (std::size_t v = 0; v < job.vertices; ++v) {
    const auto& p = job.positions[v];
    om.add_vertex(OMesh::Point(p[0], p[1], p[2]));
  }
  std::vector<std::array<std::uint32_t, 3>> kept;  // the frozen faces, as they are
  for (std::size_t f = 0; f < job.faces; ++f) {
    const auto& t = job.triangles[f];
    if (!job.frozen[f] &&
        om.add_face(OMesh::VertexHandle(int(t[0])), OMesh::VertexHandle(int(t[1])),
                    OMesh::VertexHandle(int(t[2])))
            .is_valid())
      continue;
    kept.push_back(t);
  }
  // Lock the vertices of the frozen faces: the rim of every hole survives exactly.
  om.request_vertex_status();
  om.request_edge_status();
  om.request_face_status();
  for (const auto& t : kept)
    for (std::uint32_t v : t) om.status(OMesh::VertexHandle(int(v))).set_locked(true);
  om.request_face_normals();
  om.update_face_normals();

  Decimater decimater(om);
  OpenMesh::Decimater::ModQuadricT<OMesh>::Handle quadric;
  OpenMesh::Decimater::ModNormalFlippingT<OMesh>::Handle flip;
  OpenMesh::Decimater::ModHausdorffT<OMesh>::Handle hausdorff;
  decimater.add(quadric);
  decimater.module(quadric).unset_max_err();  // the priority only
  decimater.add(flip);
  decimater.module(flip).set_max_normal_deviation(job.max_normal_deviation);
  if (job.tolerance > 0) {
    decimater.add(hausdorff);
    decimater.module(hausdorff).set_tolerance(static_cast<float>(job.tolerance));
  }
  decimater.initialize();
  const std::size_t om_faces = om.n_faces();
  const std::size_t target =
      job.target_faces > kept.size() ? job.target_faces - kept.size() : std::size_t(0);
  StopObserver observer(job, om_faces > target ? (om_faces - target) / 2 : 0);
  decimater.set_observer(&observer);
  if (job.target_faces > 0)
    decimater.decimate_to_faces(0, std::max<std::size_t>(target, 1));
  else
    decimater.decimate(0);
  decimater.set_observer(nullptr);
  stopped = observer.stopped();
  if (stopped) return;

  out = std::move(kept);
  out.reserve(out.size() + om_faces);
  for (const auto f : om.faces()) {  // vertex handles are input indices
    if (om.status(f).deleted()) continue;
    std::array<std::uint32_t, 3> t;
    int k = 0;
    for (const auto v : om.fv_range(f)) t[k++] = static_cast<std::uint32_t>(v.idx());
    out.push_back(t);
  }
}

std::string decimate(const OpenMeshJob& job, std::vector<std::array<std::uint32_t, 3>>& out,
                     bool& stopped) {
  stopped = false;
  try {
    run(job, out, stopped);
    return "";
  } catch (const std::bad_alloc&) {
    return "decimating: out of memory";
  } catch (const std::exception& e) {
    return std::string("decimating: ") + e.what();
  } catch (...) {
    return "decimating: unknown error";
  }
}

}  // namespace
}  // namespace qjulia::detail

extern "C" __attribute__((visibility("default"))) const qjulia::detail::OpenMeshApi*
qjulia_openmesh_api() {
  static const qjulia::detail::OpenMeshApi api{qjulia::detail::kOpenMeshApiVersion,
                                               &qjulia::detail::decimate};
  return &api;
}
