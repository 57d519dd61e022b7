#include "qjulia/base/validate.h"

#include <cmath>
#include <cstdint>

#include "qjulia/base/error.h"

namespace qjulia {
namespace {

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

  // The passes look for any failure first (branch-free, fast on big meshes); the messages are
  // built only when one is found.
  uint32_t largest = 0;
  for (const auto& t : mesh.triangles) {
    const uint32_t m = t[0] > t[1] ? t[0] : t[1];
    largest = m > largest ? m : largest;
    largest = t[2] > largest ? t[2] : largest;
  }
  if (nf > 0 && largest >= nv) {
    for (std::size_t f = 0; f < nf; ++f)
      for (const uint32_t v : mesh.triangles[f])
        if (v >= nv) {
          reject(source, "triangle " + std::to_string(f) + " has vertex index " +
                             std::to_string(v) + " but the mesh has " + std::to_string(nv) +
                             " vertices");
        }
  }
  bool finite = true;
  for (const auto& p : mesh.positions)
    finite &= std::isfinite(p[0]) & std::isfinite(p[1]) & std::isfinite(p[2]);
  if (!finite) {
    for (std::size_t v = 0; v < nv; ++v) {
      const auto& p = mesh.positions[v];
      if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2]))
        reject(source, "vertex " + std::to_string(v) + " has a non-finite position");
    }
  }
}

}  // namespace qjulia
