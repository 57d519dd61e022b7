#include "qjulia/base/validate.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include <cmath>
#include <cstdint>

#include "base/all_of.h"
#include "qjulia/base/error.h"

namespace qjulia {
namespace {

constexpr std::size_t kGrain = std::size_t{1} << 16;  // faces or vertices a task checks

[[noreturn]] void reject(const std::string& source, const std::string& what) {
  throw InvalidInput(source + ": " + what);
}

void check_count(const std::string& source, std::size_t count, std::size_t nv, const char* what) {
  if (count != 0 && count != nv) {
    reject(source, "the mesh has " + std::to_string(count) + " " + what + " for " +
                       std::to_string(nv) + " vertices (expected 0 or " + std::to_string(nv) + ")");
  }
}

}  // namespace

void validate_mesh(const TriMesh& mesh, const std::string& source, const MeshRequirements& req) {
  const std::size_t nv = mesh.positions.size();
  const std::size_t nf = mesh.triangles.size();
  if (nv >= UINT32_MAX) {
    reject(source, "the mesh has " + std::to_string(nv) +
                       " vertices, more than 32-bit indices can address");
  }
  if (req.faces && nf == 0) reject(source, "the mesh has no triangles");
  check_count(source, mesh.normals.size(), nv, "normals");
  check_count(source, mesh.colors.size(), nv, "colours");

  // The passes look for any failure first (branch-free, in parallel: they run on every mesh
  // written), and the messages are built only when one is found.
  const uint32_t largest = tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, nf, kGrain), uint32_t{0},
      [&](const tbb::blocked_range<std::size_t>& r, uint32_t m) {
        for (std::size_t f = r.begin(); f != r.end(); ++f) {
          const auto& t = mesh.triangles[f];
          const uint32_t a = t[0] > t[1] ? t[0] : t[1];
          m = a > m ? a : m;
          m = t[2] > m ? t[2] : m;
        }
        return m;
      },
      [](uint32_t a, uint32_t b) { return a > b ? a : b; });
  if (nf > 0 && largest >= nv) {
    for (std::size_t f = 0; f < nf; ++f)
      for (const uint32_t v : mesh.triangles[f])
        if (v >= nv) {
          reject(source, "triangle " + std::to_string(f) + " has vertex index " +
                             std::to_string(v) + " but the mesh has " + std::to_string(nv) +
                             " vertices");
        }
  }
  const bool finite = detail::all_of_parallel(nv, [&](std::size_t v) -> bool {
    const auto& p = mesh.positions[v];
    return std::isfinite(p[0]) & std::isfinite(p[1]) & std::isfinite(p[2]);
  });
  if (!finite) {
    for (std::size_t v = 0; v < nv; ++v) {
      const auto& p = mesh.positions[v];
      if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2]))
        reject(source, "vertex " + std::to_string(v) + " has a non-finite position");
    }
  }
}

}  // namespace qjulia
