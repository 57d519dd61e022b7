// decimate()'s quality method: OpenMesh's Decimater, in the module libqjulia_openmesh.so
// (openmesh_module.h). Which faces it may not touch is decided here.
#include "mesh/decimate_openmesh.h"

#include <exception>
#include <stdexcept>

#include "base/mesh_check.h"
#include "mesh/openmesh_module.h"
#include "qjulia/base/error.h"

namespace qjulia::detail {

namespace {

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

/// What the module's progress calls reach: the options, and an exception the progress
/// function threw (nothing is thrown through OpenMesh; it is rethrown once the module returns).
struct Watch {
  const OpenMeshDecimation& opts;
  std::exception_ptr error;
};

bool keep_going(double fraction, void* token) {
  Watch& w = *static_cast<Watch*>(token);
  try {
    if (w.opts.cancel && w.opts.cancel->requested()) return false;
    return !w.opts.progress || w.opts.progress(fraction);
  } catch (...) {
    w.error = std::current_exception();
    return false;
  }
}

}  // namespace

std::vector<std::array<uint32_t, 3>> decimate_openmesh(const TriMesh& mesh,
                                                       const OpenMeshDecimation& opts) {
  throw_if_cancelled(opts.cancel);
  const OpenMeshApi& api = openmesh_api();
  const std::vector<uint8_t> frozen = frozen_faces(mesh, opts.pinned);
  throw_if_cancelled(opts.cancel);
  Watch watch{opts, nullptr};
  OpenMeshJob job;
  job.positions = mesh.positions.data();
  job.vertices = mesh.positions.size();
  job.triangles = mesh.triangles.data();
  job.faces = mesh.triangles.size();
  job.frozen = frozen.data();
  job.target_faces = opts.target_faces;
  job.tolerance = opts.tolerance;
  job.max_normal_deviation = opts.max_normal_deviation;
  job.keep_going = keep_going;
  job.token = &watch;
  std::vector<std::array<uint32_t, 3>> out;
  bool stopped = false;
  const std::string why = api.decimate(job, out, stopped);
  if (watch.error) std::rethrow_exception(watch.error);
  if (!why.empty()) throw std::runtime_error(why);
  if (stopped) throw Cancelled();
  return out;
}

}  // namespace qjulia::detail
