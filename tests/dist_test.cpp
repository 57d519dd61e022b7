// The distributed stages, with ranks as threads (thread_comm.h): every number of ranks gives
// what one process gives.
#include <gtest/gtest.h>

#include <cstring>
#include <mutex>

#include "base/comm.h"
#include "grid/bricks.h"
#include "grid/grid_impl.h"
#include "qjulia/field/classify.h"
#include "qjulia/grid/sample.h"
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
      test::run_ranks(ranks, [&](detail::Comm& comm) {
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

}  // namespace
}  // namespace qjulia
