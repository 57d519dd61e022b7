// The distributed stages, with ranks as threads (thread_comm.h): every number of ranks gives
// what one process gives.
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <sstream>

#include "base/distribution.h"
#include "grid/bricks.h"
#include "grid/grid_impl.h"
#include "qjulia/field/classify.h"
#include "qjulia/grid/sample.h"
#include "qjulia/io/mesh_io.h"
#include "qjulia/pipeline/distributed.h"
#include "qjulia/pipeline/pipeline.h"
#include "qjulia/surface/extract.h"
#include "surface/part.h"
#include "thread_comm.h"

namespace qjulia {
namespace {

// A brick's content, for comparing.
struct BrickState {
  std::uint64_t key;
  detail::Bits<detail::kBrickPoints> known;
  detail::Bits<detail::kBrickCells> surface, visited;
  std::vector<float> values;
  bool operator==(const BrickState& o) const {
    return key == o.key && std::memcmp(&known, &o.known, sizeof known) == 0 &&
           std::memcmp(&surface, &o.surface, sizeof surface) == 0 &&
           std::memcmp(&visited, &o.visited, sizeof visited) == 0 && values == o.values;
  }
};

std::vector<BrickState> states(const detail::BrickList& bricks) {
  std::vector<BrickState> out;
  for (const auto& b : bricks) {
    BrickState s{b->key, b->known, b->surface, b->visited, {}};
    for (int p = 0; p < detail::kBrickPoints; ++p)
      if (b->known.test(p)) s.values.push_back(b->get(p));
    out.push_back(std::move(s));
  }
  return out;
}

TEST(Distributed, SamplingGivesTheBricksOfOneProcessForOneToFourRanks) {
  for (const auto& [name, resolution] : {std::pair<const char*, int>{"newton-cubic", 96},
                                         {"classic-julia", 150},
                                         {"rosa-rational", 120},
                                         {"sine-julia", 24}}) {
    Params p = preset(name);
    p.resolution = resolution;
    const SampledGrid one = sample(p);
    const auto expected = states(one.impl().bricks);
    for (int ranks = 1; ranks <= 4; ++ranks) {
      SCOPED_TRACE(std::string(name) + " on " + std::to_string(ranks) + " ranks");
      std::vector<std::vector<BrickState>> parts(ranks);
      std::vector<std::uint64_t> evaluations(ranks);
      test::run_ranks(ranks, [&](Comm& comm) {
        detail::Distribution dist;
        dist.comm = &comm;
        SampleOptions so;
        so.distribution = &dist;
        const SampledGrid g = sample(p, so);
        parts[comm.rank()] = states(g.impl().bricks);
        evaluations[comm.rank()] = g.evaluations();
      });
      std::vector<BrickState> all;
      std::uint64_t total = 0;
      for (int r = 0; r < ranks; ++r) {
        all.insert(all.end(), parts[r].begin(), parts[r].end());
        total += evaluations[r];
      }
      ASSERT_EQ(all.size(), expected.size());
      for (std::size_t i = 0; i < all.size(); ++i)
        ASSERT_TRUE(all[i] == expected[i]) << "brick " << i;
      EXPECT_EQ(total, one.evaluations());
    }
  }
}

// A rank's part of the extracted mesh, with what the test compares.
struct Part {
  detail::MeshPart part;
  TriMesh mesh;
  ExtractStats stats;
};

TEST(Distributed, ExtractionGivesTheMeshOfOneProcessForOneToFourRanks) {
  for (const auto& [name, resolution, color] :
       {std::tuple<const char*, int, ColorMode>{"newton-cubic", 80, ColorMode::kBasin},
        {"classic-julia", 120, ColorMode::kIterations},
        {"rosa-rational", 100, ColorMode::kNone},
        {"sine-julia", 24, ColorMode::kNone}}) {
    Params p = preset(name);
    p.resolution = resolution;
    ExtractOptions eo;
    eo.color = color;
    ExtractStats one_stats;
    const TriMesh one = extract(sample(p), eo, &one_stats);
    ASSERT_TRUE(one_stats.measure_valid);
    for (int ranks = 1; ranks <= 4; ++ranks) {
      SCOPED_TRACE(std::string(name) + " on " + std::to_string(ranks) + " ranks");
      std::vector<Part> parts(ranks);
      test::run_ranks(ranks, [&](Comm& comm) {
        detail::Distribution dist;
        dist.comm = &comm;
        SampleOptions so;
        so.distribution = &dist;
        Part& mine = parts[comm.rank()];
        mine.mesh = detail::extract_part(sample(p, so), eo, mine.stats, mine.part);
      });
      std::vector<std::array<float, 3>> positions(one.positions.size()), normals(positions.size()),
          colors(color == ColorMode::kNone ? 0 : positions.size());
      std::vector<std::array<std::uint32_t, 3>> triangles;
      std::vector<std::uint32_t> face_component;
      std::vector<char> seen(positions.size(), 0);
      for (const Part& r : parts) {
        ASSERT_EQ(r.part.vertices_total, one.positions.size());
        ASSERT_EQ(r.part.faces_total, one.triangles.size());
        ASSERT_EQ(r.part.face_first, triangles.size());
        ASSERT_EQ(r.mesh.positions.size(), r.part.edges + r.part.centres);
        for (std::size_t l = 0; l < r.mesh.positions.size(); ++l) {
          const std::size_t v =
              l < r.part.edges ? r.part.edge_first + l : r.part.centre_first + (l - r.part.edges);
          ASSERT_LT(v, positions.size());
          ASSERT_FALSE(seen[v]) << "vertex " << v << " on two ranks";
          seen[v] = 1;
          positions[v] = r.mesh.positions[l];
          normals[v] = r.mesh.normals[l];
          if (!colors.empty()) colors[v] = r.mesh.colors[l];
        }
        // The ghosts are copies of the up rank's vertices.
        for (const auto& t : r.mesh.triangles)
          for (std::uint32_t v : t)
            ASSERT_EQ(r.part.position(r.mesh, v), one.positions[v]) << "vertex " << v;
        triangles.insert(triangles.end(), r.mesh.triangles.begin(), r.mesh.triangles.end());
        face_component.insert(face_component.end(), r.stats.face_component.begin(),
                              r.stats.face_component.end());
        EXPECT_EQ(r.stats.measure_valid, one_stats.measure_valid);
      }
      EXPECT_EQ(positions, one.positions);
      EXPECT_EQ(normals, one.normals);
      EXPECT_EQ(colors, one.colors);
      EXPECT_EQ(triangles, one.triangles);
      EXPECT_EQ(face_component, one_stats.face_component);
      const MeshMeasure& m = parts[0].stats.measure;
      const MeshMeasure& e = one_stats.measure;
      EXPECT_EQ(m.vertices, e.vertices);
      EXPECT_EQ(m.edges, e.edges);
      EXPECT_EQ(m.euler, e.euler);
      EXPECT_EQ(m.volume, e.volume);
      EXPECT_EQ(m.area, e.area);
      EXPECT_EQ(m.bbox_min, e.bbox_min);
      EXPECT_EQ(m.bbox_max, e.bbox_max);
      ASSERT_EQ(m.components.size(), e.components.size());
      for (std::size_t c = 0; c < e.components.size(); ++c) {
        EXPECT_EQ(m.components[c].faces, e.components[c].faces);
        EXPECT_EQ(m.components[c].volume, e.components[c].volume);
        EXPECT_EQ(m.components[c].genus, e.components[c].genus);
      }
      EXPECT_EQ(parts[0].stats.component_bbox, one_stats.component_bbox);
    }
  }
}

std::string file_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// The file one process writes, and the file K ranks write, for each K.
void expect_same_files(const Params& p, const std::string& ext, bool expect_gathered,
                       std::size_t* removed_components = nullptr) {
  const std::string dir = testing::TempDir();
  PipelineOptions po;
  po.outputs = {format_from_path("x" + ext)};
  ExportOptions eo;
  eo.params_json = params_to_json(p);
  const PipelineResult one = run_pipeline(p, po);
  const std::string expected_path = dir + "one" + ext;
  write_mesh(expected_path, one.mesh, eo);
  const std::string expected = file_bytes(expected_path);
  ASSERT_GT(expected.size(), 100u);
  if (removed_components && one.stats.clean)
    *removed_components += one.stats.clean->removed_components;
  for (int ranks = 1; ranks <= 4; ++ranks) {
    SCOPED_TRACE(std::to_string(ranks) + " ranks, " + ext);
    const std::string path = dir + "dist" + std::to_string(ranks) + ext;
    std::vector<RunStats> stats(ranks);
    test::run_ranks(ranks, [&](Comm& comm) {
      DistributedRun run = run_pipeline_distributed(p, po, comm);
      EXPECT_EQ(run.gathered(), expect_gathered);
      write_distributed(path, run, eo, comm);
      stats[comm.rank()] = run.result.stats;
    });
    EXPECT_TRUE(file_bytes(path) == expected) << path << " differs from " << expected_path;
    const RunStats& s = stats[0];
    EXPECT_EQ(s.measure.faces, one.stats.measure.faces);
    EXPECT_EQ(s.measure.volume, one.stats.measure.volume);
    EXPECT_EQ(s.measure.components.size(), one.stats.measure.components.size());
    EXPECT_EQ(s.evaluations, one.stats.evaluations);
    EXPECT_EQ(s.refine_evaluations, one.stats.refine_evaluations);
    ASSERT_EQ(s.ranks.size(), static_cast<std::size_t>(ranks));
    std::uint64_t bricks = 0;
    int busy = 0;
    for (const auto& r : s.ranks) {
      bricks += r.bricks;
      busy += r.bricks > 0;
    }
    EXPECT_GT(bricks, 0u);
    EXPECT_GE(busy, std::min(ranks, 2)) << "the bricks were not dealt to several ranks";
    std::filesystem::remove(path);
  }
  std::filesystem::remove(expected_path);
}

TEST(Distributed, ThePipelineWritesTheFileOfOneProcessForOneToFourRanks) {
  std::size_t removed = 0;
  for (const auto& [name, resolution] : {std::pair<const char*, int>{"newton-cubic", 64},
                                         {"rosa-rational", 72},
                                         {"classic-julia", 80}}) {
    SCOPED_TRACE(name);
    Params p = preset(name);
    p.resolution = resolution;
    expect_same_files(p, ".ply", false, &removed);
    expect_same_files(p, ".stl", false);
  }
  EXPECT_GT(removed, 0u) << "the dust removal across ranks was not exercised";
}

TEST(Distributed, ColoursClipAndMinComponentGiveTheFileOfOneProcess) {
  Params p = preset("newton-cubic");
  p.resolution = 60;
  p.mesh.color = ColorMode::kBasin;
  p.mesh.min_component = 1e-3;
  p.mesh.clip.push_back({{1, 0.3, 0}, 0.2});
  expect_same_files(p, ".ply", false);
}

TEST(Distributed, StagesOnTheWholeMeshRunOnRankZeroAfterAGather) {
  Params p = preset("classic-julia");
  p.resolution = 64;
  p.mesh.faces = 3000;
  expect_same_files(p, ".ply", true);
  Params q = preset("newton-cubic");
  q.resolution = 48;
  expect_same_files(q, ".glb", true);
  expect_same_files(q, ".obj", true);
}

TEST(Distributed, TheGridIsNotGatheredSoVdbIsRefusedOnEveryRank) {
  Params p = preset("newton-cubic");
  p.resolution = 32;
  PipelineOptions po;
  po.keep_grid = true;
  po.outputs = {MeshFormat::kPly};
  std::vector<int> refused(2, 0);
  test::run_ranks(2, [&](Comm& comm) {
    try {
      run_pipeline_distributed(p, po, comm);
    } catch (const InvalidInput& e) {
      refused[comm.rank()] = std::string(e.what()).find("--vdb") != std::string::npos;
    }
  });
  EXPECT_EQ(refused, std::vector<int>({1, 1}));
}

TEST(Distributed, BadParametersThrowTheSameErrorOnEveryRank) {
  Params p = preset("newton-cubic");
  p.formula = "h^^2";
  std::vector<std::string> messages(3);
  test::run_ranks(3, [&](Comm& comm) {
    try {
      run_pipeline_distributed(p, {}, comm);
    } catch (const InvalidInput& e) {
      messages[comm.rank()] = e.what();
    }
  });
  EXPECT_FALSE(messages[0].empty());
  EXPECT_EQ(messages[1], messages[0]);
  EXPECT_EQ(messages[2], messages[0]);
}

}  // namespace
}  // namespace qjulia
