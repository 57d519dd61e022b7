// Meshes the unit-ball preset at a small resolution with an installed qjulia; prints its volume.
#include <cstdio>

#include "qjulia/pipeline/pipeline.h"

int main() {
  qjulia::Params params = qjulia::preset("unit-ball");
  params.resolution = 32;
  const qjulia::MeshMeasure m = qjulia::run_pipeline(params).stats.measure;
  std::printf("unit ball at resolution 32: %zu faces, %s, volume %.4f (4/3 pi = 4.1888)\n", m.faces,
              m.closed ? "closed" : "open", m.volume);
  return m.closed ? 0 : 1;
}
