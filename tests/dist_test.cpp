// The distributed stages, with ranks as threads (thread_comm.h): every number of ranks gives
// what one process gives.
#include <gtest/gtest.h>

#include <cstring>
#include <mutex>

#include "base/distribution.h"
#include "grid/bricks.h"
#include "grid/grid_impl.h"
#include "qjulia/field/classify.h"
#include "qjulia/grid/sample.h"
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

}  // namespace
}  // namespace qjulia
