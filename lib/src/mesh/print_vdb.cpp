// thicken(): OpenVDB level-set morphology. Kept apart from print.cpp (OpenVDB compiles slowly).
#include <openvdb/openvdb.h>
#include <openvdb/tools/Composite.h>
#include <openvdb/tools/LevelSetRebuild.h>
#include <openvdb/tools/MeshToVolume.h>
#include <openvdb/tools/VolumeToMesh.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "base/mesh_check.h"
#include "mesh/stage_progress.h"
#include "qjulia/base/error.h"
#include "qjulia/base/validate.h"
#include "qjulia/mesh/clean.h"
#include "qjulia/mesh/print.h"

namespace qjulia {

namespace {

using openvdb::FloatGrid;

/// Lets OpenVDB's long tools stop when the token is requested (they then return early; the
/// caller throws Cancelled).
class CancelInterrupter : public openvdb::util::NullInterrupter {
 public:
  explicit CancelInterrupter(const CancelToken* token) : token_(token) {}
  bool wasInterrupted(int = -1) override { return token_ && token_->requested(); }

 private:
  const CancelToken* token_;
};

/// Subtracts c from every value of a level set (voxels, tiles and background): the zero level
/// moves outward by c.
void shift_values(FloatGrid& grid, float c) {
  for (auto it = grid.tree().beginValueAll(); it; ++it) it.setValue(it.getValue() - c);
  grid.tree().root().setBackground(grid.background() - c, /*updateChildNodes=*/false);
}

/// The signed distance field of `mesh` on a grid of `voxel`, `band` voxels wide on both sides.
FloatGrid::Ptr to_level_set(const TriMesh& mesh, double voxel, float band,
                            CancelInterrupter& interrupter) {
  auto xform = openvdb::math::Transform::createLinearTransform(voxel);
  std::vector<openvdb::Vec3s> points;
  points.reserve(mesh.positions.size());
  for (const auto& p : mesh.positions) points.emplace_back(p[0], p[1], p[2]);
  std::vector<openvdb::Vec3I> tris;
  tris.reserve(mesh.triangles.size());
  for (const auto& t : mesh.triangles) tris.emplace_back(t[0], t[1], t[2]);
  return openvdb::tools::meshToSignedDistanceField<FloatGrid>(
      interrupter, *xform, points, tris, std::vector<openvdb::Vec4I>(), band, band);
}

/// The zero level of `grid` as an outward triangle mesh with compact vertices.
TriMesh from_level_set(const FloatGrid& grid) {
  std::vector<openvdb::Vec3s> points;
  std::vector<openvdb::Vec3I> tris;
  std::vector<openvdb::Vec4I> quads;
  openvdb::tools::volumeToMesh(grid, points, tris, quads, 0.0, 0.0);
  TriMesh out;
  out.positions.reserve(points.size());
  for (const auto& p : points) out.positions.push_back({p.x(), p.y(), p.z()});
  out.triangles.reserve(tris.size() + 2 * quads.size());
  // OpenVDB winds its polygons clockwise seen from outside; reverse them.
  for (const auto& t : tris) out.triangles.push_back({t[0], t[2], t[1]});
  for (const auto& q : quads) {
    out.triangles.push_back({q[0], q[2], q[1]});
    out.triangles.push_back({q[0], q[3], q[2]});
  }
  if (detail::signed_volume(out) < 0)
    for (auto& t : out.triangles) std::swap(t[1], t[2]);
  detail::compact_vertices(out);
  return out;
}

}  // namespace

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
  openvdb::initialize();
  detail::report_progress(opts.progress, opts.cancel, 0.0);

  CancelInterrupter interrupter(opts.cancel);
  const double r = opts.min_thickness / 2;
  // Bands (in voxels) wide enough that erosion and dilation by r see true distances.
  const float band = static_cast<float>(r / voxel + 3);
  FloatGrid::Ptr solid = to_level_set(mesh, voxel, band, interrupter);
  detail::report_progress(opts.progress, opts.cancel, 0.2);

  // Opening: erode by r (one rebuild at -r), dilate by r. A distance field of the eroded set
  // minus r is one of the opened set outside it (exact) with the right sign inside, which is all
  // the CSG below needs, so the dilation is a shift, not a second rebuild; so is the 1.5 voxel
  // margin that keeps discretisation noise on thick parts out of the thin set.
  const float fr = static_cast<float>(r);
  FloatGrid::Ptr opened =
      openvdb::tools::levelSetRebuild(*solid, -fr, band, 3.0f, nullptr, &interrupter);
  detail::report_progress(opts.progress, opts.cancel, 0.3);
  shift_values(*opened, fr + static_cast<float>(1.5 * voxel));
  detail::report_progress(opts.progress, opts.cancel, 0.4);
  // What the opening loses is thinner than min_thickness.
  FloatGrid::Ptr thin = openvdb::tools::csgDifferenceCopy(*solid, *opened);
  opened.reset();
  // The CSG result is not a distance field of the thin set (near thick walls it is ~the
  // margin, not far away); re-distance it from its zero level, wide enough to dilate by r.
  thin = openvdb::tools::levelSetRebuild(*thin, 0.0f, band, 3.0f, nullptr, &interrupter);
  detail::report_progress(opts.progress, opts.cancel, 0.6);

  // Thin parts dilated by r (a shift of their distance field), joined to the solid.
  FloatGrid::Ptr result = solid;
  if (thin->activeVoxelCount() > 0) {
    shift_values(*thin, fr);
    openvdb::tools::csgUnion(*result, *thin);
  }
  thin.reset();
  detail::report_progress(opts.progress, opts.cancel, 0.8);

  TriMesh out = from_level_set(*result);
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
