#include "qjulia/grid/sample.h"

#include <gtest/gtest.h>
#include <openvdb/io/File.h>
#include <openvdb/openvdb.h>
#include <tbb/global_control.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>

#include "qjulia/field/classify.h"
#include "qjulia/field/params.h"

namespace qjulia {
namespace {

TEST(Sample, GridGeometryPutsPointsAtVoxelCentres) {
  Params p = preset("unit-ball");
  p.resolution = 10;
  p.bounds = {{-1, -0.5, 0}, {1, 0.5, 0.3}};
  const GridGeometry g = grid_geometry(p);
  EXPECT_DOUBLE_EQ(g.voxel, 0.2);
  EXPECT_DOUBLE_EQ(g.origin[0], -0.9);
  EXPECT_EQ(g.points[0], 10);
  EXPECT_EQ(g.points[1], 5);
  EXPECT_EQ(g.points[2], 1);  // 0.3 / 0.2 = 1.5 voxels: one centre inside
}

TEST(Sample, VdbFileReadsBackAsOneFloatGridWithTheSampledValuesAndMetadata) {
  Params p = preset("classic-julia");
  p.resolution = 32;
  const SampledGrid grid = sample(p);
  const auto path = (std::filesystem::temp_directory_path() /
                     ("qjulia_sample_test_" + std::to_string(::getpid()) + ".vdb"))
                        .string();
  grid.write_vdb(path, params_to_json(p));
  openvdb::initialize();
  openvdb::io::File file(path);
  file.open();
  const auto grids = file.getGrids();
  file.close();
  std::remove(path.c_str());
  ASSERT_EQ(grids->size(), 1u);
  const auto f = openvdb::gridPtrCast<openvdb::FloatGrid>((*grids)[0]);
  ASSERT_TRUE(f);
  EXPECT_EQ(f->getName(), "F");
  EXPECT_EQ(f->activeVoxelCount(), grid.active_voxels());
  EXPECT_EQ(f->metaValue<std::string>("qjulia_parameters"), params_to_json(p));
  // Every stored value is the classifier's field at that point.
  const Solid solid(p);
  const auto geo = grid_geometry(p);
  std::size_t checked = 0;
  for (auto it = f->cbeginValueOn(); it; ++it, ++checked) {
    const openvdb::Coord c = it.getCoord();
    EXPECT_EQ(*it, solid.field(geo.origin[0] + c.x() * geo.voxel, geo.origin[1] + c.y() * geo.voxel,
                               geo.origin[2] + c.z() * geo.voxel));
    // The grid's transform maps the index to the same point.
    const openvdb::Vec3d w = f->indexToWorld(c);
    EXPECT_NEAR(w.x(), geo.origin[0] + c.x() * geo.voxel, 1e-9);
  }
  EXPECT_GT(checked, 1000u);
}

// The grid written with one thread and with two holds the same values: the same active voxels
// with the same values and the same inactive tiles (the files differ only by the random id
// OpenVDB writes into every file).
TEST(Sample, TheVdbGridHasTheSameValuesForOneAndTwoThreads) {
  openvdb::initialize();
  const auto dir = std::filesystem::temp_directory_path();
  const auto write = [&](int threads, const std::string& name) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    Params p = preset("newton-cubic");
    p.resolution = 72;
    const std::string path = (dir / (name + std::to_string(::getpid()) + ".vdb")).string();
    sample(p).write_vdb(path, params_to_json(p));
    openvdb::io::File file(path);
    file.open();
    const auto grids = file.getGrids();
    file.close();
    std::remove(path.c_str());
    return openvdb::gridPtrCast<openvdb::FloatGrid>((*grids)[0]);
  };
  const auto one = write(1, "qjulia_sample_t1_"), two = write(2, "qjulia_sample_t2_");
  ASSERT_TRUE(one && two);
  ASSERT_GT(one->activeVoxelCount(), 1000u);
  EXPECT_EQ(one->activeVoxelCount(), two->activeVoxelCount());
  EXPECT_EQ(one->background(), two->background());
  auto acc = two->getConstAccessor();
  std::size_t compared = 0;
  for (auto it = one->cbeginValueAll(); it; ++it) {
    openvdb::CoordBBox box;
    it.getBoundingBox(box);
    ASSERT_EQ(acc.isValueOn(box.min()), it.isValueOn()) << box.min();
    ASSERT_EQ(acc.getValue(box.min()), *it) << box.min();
    ++compared;
  }
  EXPECT_GT(compared, one->activeVoxelCount() / 2);
}

}  // namespace
}  // namespace qjulia
