// libqjulia_vdb.so: the OpenVDB code of qjulia (see vdb_module.h). It uses nothing of
// libqjulia, only OpenVDB and the standard library.
#include "base/vdb_module.h"

#include <openvdb/io/File.h>
#include <openvdb/openvdb.h>
#include <openvdb/tools/Composite.h>
#include <openvdb/tools/LevelSetRebuild.h>
#include <openvdb/tools/MeshToVolume.h>
#include <openvdb/tools/VolumeToMesh.h>

#include <mutex>

namespace qjulia::detail {
namespace {

using openvdb::FloatGrid;

void initialize() {
  static std::once_flag once;
  std::call_once(once, [] { openvdb::initialize(); });
}

void write_grid(const std::string& path, const VdbGrid& g) {
  initialize();
  auto grid = FloatGrid::create(g.background);
  const int s = g.block;
  // Uniform interior blocks first, as inactive tiles; the evaluated points then override.
  for (const auto& c : g.interior)
    grid->tree().fill(
        openvdb::CoordBBox(openvdb::Coord(c[0] * s, c[1] * s, c[2] * s),
                           openvdb::Coord(c[0] * s + s - 1, c[1] * s + s - 1, c[2] * s + s - 1)),
        -g.background, false);
  auto acc = grid->getAccessor();
  g.each_value(
      g.source,
      [](void* sink, int i, int j, int k, float v) {
        static_cast<FloatGrid::Accessor*>(sink)->setValueOn(openvdb::Coord(i, j, k), v);
      },
      &acc);
  grid->setName(g.name);
  grid->setTransform(openvdb::math::Transform::createLinearTransform(g.voxel));
  grid->transform().postTranslate(openvdb::Vec3d(g.origin[0], g.origin[1], g.origin[2]));
  for (const auto& [key, value] : g.metadata) grid->insertMeta(key, openvdb::StringMetadata(value));
  openvdb::io::File out(path);
  openvdb::GridPtrVec grids{grid};
  out.write(grids);
  out.close();
}

/// Lets OpenVDB's long tools stop when asked (they then return early; the caller throws).
class Interrupter : public openvdb::util::NullInterrupter {
 public:
  explicit Interrupter(const std::function<bool()>& f) : f_(f) {}
  bool wasInterrupted(int = -1) override { return f_ && f_(); }

 private:
  const std::function<bool()>& f_;
};

/// Subtracts c from every value of a level set (voxels, tiles and background): the zero level
/// moves outward by c.
void shift_values(FloatGrid& grid, float c) {
  for (auto it = grid.tree().beginValueAll(); it; ++it) it.setValue(it.getValue() - c);
  grid.tree().root().setBackground(grid.background() - c, /*updateChildNodes=*/false);
}

void thicken(const VdbPositions& positions, const VdbTriangles& triangles, const VdbThicken& o,
             VdbPositions& out_positions, VdbTriangles& out_triangles) {
  initialize();
  auto progress = [&](double f) {
    if (o.progress) o.progress(f);
  };
  Interrupter interrupter(o.interrupted);
  const double r = o.r;
  // Bands (in voxels) wide enough that erosion and dilation by r see true distances.
  const float band = static_cast<float>(r / o.voxel + 3);
  FloatGrid::Ptr solid;
  {
    // The signed distance field of the mesh, `band` voxels wide on both sides.
    auto xform = openvdb::math::Transform::createLinearTransform(o.voxel);
    std::vector<openvdb::Vec3s> points;
    points.reserve(positions.size());
    for (const auto& p : positions) points.emplace_back(p[0], p[1], p[2]);
    std::vector<openvdb::Vec3I> tris;
    tris.reserve(triangles.size());
    for (const auto& t : triangles) tris.emplace_back(t[0], t[1], t[2]);
    solid = openvdb::tools::meshToSignedDistanceField<FloatGrid>(
        interrupter, *xform, points, tris, std::vector<openvdb::Vec4I>(), band, band);
  }
  progress(0.2);

  // Opening: erode by r (one rebuild at -r), dilate by r. A distance field of the eroded set
  // minus r is one of the opened set outside it (exact) with the right sign inside, which is all
  // the CSG below needs, so the dilation is a shift, not a second rebuild; so is the 1.5 voxel
  // margin that keeps discretisation noise on thick parts out of the thin set.
  const float fr = static_cast<float>(r);
  FloatGrid::Ptr opened =
      openvdb::tools::levelSetRebuild(*solid, -fr, band, 3.0f, nullptr, &interrupter);
  progress(0.3);
  shift_values(*opened, fr + static_cast<float>(1.5 * o.voxel));
  progress(0.4);
  // What the opening loses is thinner than min_thickness.
  FloatGrid::Ptr thin = openvdb::tools::csgDifferenceCopy(*solid, *opened);
  opened.reset();
  // The CSG result is not a distance field of the thin set (near thick walls it is ~the
  // margin, not far away); re-distance it from its zero level, wide enough to dilate by r.
  thin = openvdb::tools::levelSetRebuild(*thin, 0.0f, band, 3.0f, nullptr, &interrupter);
  progress(0.6);

  // Thin parts dilated by r (a shift of their distance field), joined to the solid.
  FloatGrid::Ptr result = solid;
  if (thin->activeVoxelCount() > 0) {
    shift_values(*thin, fr);
    openvdb::tools::csgUnion(*result, *thin);
  }
  thin.reset();
  progress(0.8);

  // The zero level. OpenVDB winds its polygons clockwise seen from outside; reversed here.
  std::vector<openvdb::Vec3s> points;
  std::vector<openvdb::Vec3I> tris;
  std::vector<openvdb::Vec4I> quads;
  openvdb::tools::volumeToMesh(*result, points, tris, quads, 0.0, 0.0);
  out_positions.clear();
  out_positions.reserve(points.size());
  for (const auto& p : points) out_positions.push_back({p.x(), p.y(), p.z()});
  out_triangles.clear();
  out_triangles.reserve(tris.size() + 2 * quads.size());
  for (const auto& t : tris) out_triangles.push_back({t[0], t[2], t[1]});
  for (const auto& q : quads) {
    out_triangles.push_back({q[0], q[2], q[1]});
    out_triangles.push_back({q[0], q[3], q[2]});
  }
}

}  // namespace
}  // namespace qjulia::detail

extern "C" __attribute__((visibility("default"))) const qjulia::detail::VdbApi* qjulia_vdb_api() {
  static const qjulia::detail::VdbApi api{qjulia::detail::kVdbApiVersion,
                                          &qjulia::detail::write_grid, &qjulia::detail::thicken};
  return &api;
}
