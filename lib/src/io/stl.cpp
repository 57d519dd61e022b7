// Binary STL writer: 80-byte header naming qjulia and the unit, one face normal per triangle.
#include <cstring>

#include "qjulia/base/atomic_file.h"
#include "io/formats.h"

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__,
              "the STL writer assumes a little-endian host");

namespace qjulia::detail {

void write_stl(const std::string& path, const ExportData& data) {
  const TriMesh& mesh = data.mesh;
  // The header must not start with "solid" (readers would take the file for ASCII STL).
  std::string text = data.generator + " binary STL, unit: " +
                     (data.unit.empty() ? std::string("model units") : data.unit);
  char header[80];
  std::memset(header, ' ', sizeof header);
  std::memcpy(header, text.data(), std::min(text.size(), sizeof header));
  const uint32_t count = uint32_t(mesh.triangles.size());

  AtomicFile file(path);
  BufferedWriter out(file);
  out.put(header, sizeof header);
  out.put(reinterpret_cast<const char*>(&count), 4);
  for (const auto& t : mesh.triangles) {
    char* p = out.reserve(50);
    const auto n = face_normal(mesh.positions[t[0]], mesh.positions[t[1]], mesh.positions[t[2]]);
    std::memcpy(p, n.data(), 12);
    for (int k = 0; k < 3; ++k) std::memcpy(p + 12 + 12 * k, mesh.positions[t[k]].data(), 12);
    p[48] = p[49] = 0;
    out.advance(50);
  }
  out.flush();
  file.commit();
}

}  // namespace qjulia::detail
