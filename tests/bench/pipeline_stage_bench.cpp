// Sampling and extraction of a preset, each timed (best of R runs), in-process: the two stages
// the core's speed is made of, without process start, the memory estimate and file writing.
// usage: pipeline_stage_bench [PRESET] [RESOLUTION] [RUNS]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <string>

#include "qjulia/field/classify.h"
#include "qjulia/field/params.h"
#include "qjulia/grid/sample.h"
#include "qjulia/surface/extract.h"

using namespace qjulia;
int main(int argc, char** argv) {
  const std::string name = argc > 1 ? argv[1] : "classic-julia";
  Params p = preset(name);
  p.resolution = argc > 2 ? std::stoi(argv[2]) : 512;
  const int runs = argc > 3 ? std::stoi(argv[3]) : 3;
  const Solid solid(p);
  double best_sample = 1e300, best_extract = 1e300;
  std::size_t faces = 0;
  for (int r = 0; r < runs; ++r) {
    const auto t0 = std::chrono::steady_clock::now();
    SampledGrid grid = sample(solid);
    const auto t1 = std::chrono::steady_clock::now();
    ExtractStats stats;
    const TriMesh mesh = extract(std::move(grid), ExtractOptions{}, &stats);
    const auto t2 = std::chrono::steady_clock::now();
    best_sample = std::min(best_sample, std::chrono::duration<double>(t1 - t0).count());
    best_extract = std::min(best_extract, std::chrono::duration<double>(t2 - t1).count());
    faces = mesh.triangles.size();
  }
  std::printf("%s %d: sample %.3f s, extract %.3f s, %zu faces\n", name.c_str(), p.resolution,
              best_sample, best_extract, faces);
}
