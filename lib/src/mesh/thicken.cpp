// thicken(): level-set morphology through OpenVDB (the qjulia_vdb module, loaded on first use).
#include <algorithm>
#include <cmath>
#include <string>

#include "base/mesh_check.h"
#include "base/stage_progress.h"
#include "base/vdb_module.h"
#include "qjulia/base/error.h"
#include "qjulia/base/validate.h"
#include "qjulia/mesh/clean.h"
#include "qjulia/mesh/print.h"

namespace qjulia {

TriMesh thicken(const TriMesh& mesh, const ThickenOptions& opts) {
  validate_mesh(mesh, "thicken");
  if (!(opts.min_thickness > 0) || !std::isfinite(opts.min_thickness))
    throw InvalidInput("thicken: min_thickness must be > 0, got " +
                       std::to_string(opts.min_thickness));
  if (!(opts.voxel_size >= 0) || !std::isfinite(opts.voxel_size))
    throw InvalidInput("thicken: voxel_size must be >= 0, got " + std::to_string(opts.voxel_size));
  const double voxel = opts.voxel_size > 0 ? opts.voxel_size : opts.min_thickness / 4;
  if (mesh.triangles.empty()) return mesh;
  double extent = 0;
  for (const auto& p : mesh.positions)
    for (float c : p) extent = std::max(extent, std::abs(double(c)));
  if (extent / voxel > 1e9)
    throw InvalidInput("thicken: voxel_size " + std::to_string(voxel) +
                       " is too small for a mesh of extent " + std::to_string(extent));
  const detail::VdbApi& vdb = detail::vdb_api();
  detail::report_progress(opts.progress, opts.cancel, 0.0);

  const double r = opts.min_thickness / 2;
  detail::VdbThicken v;
  v.voxel = voxel;
  v.r = r;
  v.interrupted = [&] { return opts.cancel && opts.cancel->requested(); };
  v.progress = [&](double f) { detail::report_progress(opts.progress, opts.cancel, f); };
  TriMesh out;
  vdb.thicken(mesh.positions, mesh.triangles, v, out.positions, out.triangles);
  detail::report_progress(opts.progress, opts.cancel, 0.9);
  if (detail::signed_volume(out) < 0)
    for (auto& t : out.triangles) std::swap(t[1], t[2]);
  detail::compact_vertices(out);
  // Closing crevices leaves tiny enclosed voids (inward components of a few voxels); voids and
  // specks below r^3 are not printable features. A dilated thin part is >= 4/3 pi r^3: kept.
  CleanOptions copts;
  copts.min_component_volume = r * r * r;
  copts.cancel = opts.cancel;
  out = clean(out, copts);
  detail::report_progress(opts.progress, opts.cancel, 1.0);
  return out;
}

}  // namespace qjulia
