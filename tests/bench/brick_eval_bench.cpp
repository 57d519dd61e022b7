// Cost of evaluating points of surface bricks through the batched kernel, by batch size.
#include <atomic>
#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#include "grid/bricks.h"
#include "qjulia/field/classify.h"
#include "qjulia/field/params.h"
#include "qjulia/grid/sample.h"

using namespace qjulia;
int main(int argc, char** argv) {
  const std::string preset = argc > 1 ? argv[1] : "classic-julia";
  const int res = argc > 2 ? std::stoi(argv[2]) : 512;
  Params p = qjulia::preset(preset);
  p.resolution = res;
  Solid solid(p);
  GridGeometry geo = grid_geometry(p);
  SampleOptions so;
  detail::BrickList bricks;
  const int reps = argc > 4 ? std::stoi(argv[4]) : 5;
  for (int rep = 0; rep < reps; ++rep) {
    const auto t0 = std::chrono::steady_clock::now();
    detail::BrickSampler bs(solid, geo, so);
    bricks = bs.run();
    const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::printf("sampler %.3f s, %llu evaluations\n", t, (unsigned long long)bs.evaluations());
  }
  if (argc > 3) return 0;
  std::vector<double> x, y, z;
  for (auto& b : bricks) {
    if (!b->surface.any()) continue;
    const auto& at = b->at;
    for (int a = 0; a < 9; ++a)
      for (int bb = 0; bb < 9; ++bb)
        for (int c = 0; c < 9; ++c) {
          x.push_back(geo.origin[0] + (at.x * 8 + a) * geo.voxel);
          y.push_back(geo.origin[1] + (at.y * 8 + bb) * geo.voxel);
          z.push_back(geo.origin[2] + (at.z * 8 + c) * geo.voxel);
        }
    if (x.size() > 2000000) break;
  }
  std::vector<float> out(x.size());
  for (std::size_t batch : {4, 16, 64, 256, 729, 4096, 65536}) {
    for (int which = 0; which < 2; ++which) {
      auto t2 = std::chrono::steady_clock::now();
      for (std::size_t i = 0; i < x.size(); i += batch) {
        const std::size_t m = std::min(batch, x.size() - i);
        if (which == 0)
          solid.classifier().field(x.data() + i, y.data() + i, z.data() + i, m, out.data() + i);
        else
          solid.field(x.data() + i, y.data() + i, z.data() + i, m, out.data() + i);
      }
      auto t3 = std::chrono::steady_clock::now();
      double s = std::chrono::duration<double>(t3 - t2).count();
      std::printf("%s batch %6zu: %.1f ns/point\n", which ? "solid     " : "classifier", batch,
                  1e9 * s / x.size());
    }
  }
}
