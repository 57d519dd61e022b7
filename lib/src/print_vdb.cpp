// thicken(): OpenVDB level-set morphology. Kept apart from print.cpp (OpenVDB compiles slowly).
#include <openvdb/openvdb.h>
#include <openvdb/tools/Composite.h>
#include <openvdb/tools/LevelSetRebuild.h>
#include <openvdb/tools/MeshToVolume.h>
#include <openvdb/tools/VolumeToMesh.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "detail/mesh_check.h"
#include "qjulia/error.h"
#include "qjulia/print.h"

namespace qjulia {

namespace {
void report_progress(const ProgressFn& progress, double fraction) {
  if (progress && !progress(fraction)) throw Cancelled();
}
}  // namespace

TriMesh thicken(const TriMesh& mesh, const ThickenOptions& opts) {
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
  report_progress(opts.progress, 0.0);

  using openvdb::FloatGrid;
  const double r = opts.min_thickness / 2;
  // Bands (in voxels) wide enough that erosion and dilation by r see true distances.
  const float band = static_cast<float>(r / voxel + 3);
  auto xform = openvdb::math::Transform::createLinearTransform(voxel);
  std::vector<openvdb::Vec3s> points;
  points.reserve(mesh.positions.size());
  for (const auto& p : mesh.positions) points.emplace_back(p[0], p[1], p[2]);
  std::vector<openvdb::Vec3I> tris;
  tris.reserve(mesh.triangles.size());
  for (const auto& t : mesh.triangles) tris.emplace_back(t[0], t[1], t[2]);
  FloatGrid::Ptr solid = openvdb::tools::meshToSignedDistanceField<FloatGrid>(
      *xform, points, tris, std::vector<openvdb::Vec4I>(), band, band);
  report_progress(opts.progress, 0.2);

  // Opening: erode by r, dilate by r. What the opening loses (minus a 1.5 voxel margin against
  // discretisation noise on thick parts) is thinner than min_thickness.
  const float fr = static_cast<float>(r);
  FloatGrid::Ptr eroded = openvdb::tools::levelSetRebuild(*solid, -fr, band, band);
  FloatGrid::Ptr opened = openvdb::tools::levelSetRebuild(*eroded, fr, band, band);
  eroded.reset();
  report_progress(opts.progress, 0.4);
  FloatGrid::Ptr margin =
      openvdb::tools::levelSetRebuild(*opened, static_cast<float>(1.5 * voxel), band, band);
  opened.reset();
  FloatGrid::Ptr thin = openvdb::tools::csgDifferenceCopy(*solid, *margin);
  margin.reset();
  // The CSG result is not a distance field of the thin set (near thick walls it is ~the
  // margin, not far away); re-distance it from its zero level before dilating.
  thin = openvdb::tools::levelSetRebuild(*thin, 0.0f, band, band);
  report_progress(opts.progress, 0.6);

  // Thin parts dilated by r, joined to the solid.
  FloatGrid::Ptr result = solid;
  if (thin->activeVoxelCount() > 0) {
    FloatGrid::Ptr grown = openvdb::tools::levelSetRebuild(*thin, fr, 3.0f, 3.0f);
    openvdb::tools::csgUnion(*result, *grown);
  }
  thin.reset();
  report_progress(opts.progress, 0.8);

  std::vector<openvdb::Vec3s> out_points;
  std::vector<openvdb::Vec3I> out_tris;
  std::vector<openvdb::Vec4I> out_quads;
  openvdb::tools::volumeToMesh(*result, out_points, out_tris, out_quads, 0.0, 0.0);
  TriMesh out;
  out.positions.reserve(out_points.size());
  for (const auto& p : out_points) out.positions.push_back({p.x(), p.y(), p.z()});
  out.triangles.reserve(out_tris.size() + 2 * out_quads.size());
  // OpenVDB winds its polygons clockwise seen from outside; reverse them.
  for (const auto& t : out_tris) out.triangles.push_back({t[0], t[2], t[1]});
  for (const auto& q : out_quads) {
    out.triangles.push_back({q[0], q[2], q[1]});
    out.triangles.push_back({q[0], q[3], q[2]});
  }
  if (detail::signed_volume(out) < 0)
    for (auto& t : out.triangles) std::swap(t[1], t[2]);
  detail::compact_vertices(out);
  report_progress(opts.progress, 1.0);
  return out;
}

}  // namespace qjulia
