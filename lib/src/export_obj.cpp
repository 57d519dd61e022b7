// Wavefront OBJ writer: `v x y z [r g b]`, `vn`, `f a//a b//b c//c`, parameters as comments.
#include <charconv>

#include "detail/atomic_file.h"
#include "detail/mesh_io.h"

namespace qjulia::detail {
namespace {

inline char* put_float(char* p, float f) {
  *p++ = ' ';
  return std::to_chars(p, p + 32, f).ptr;  // shortest text that reads back to the same float
}

inline char* put_index(char* p, uint32_t i) {
  *p++ = ' ';
  char* start = p;
  p = std::to_chars(p, p + 12, i).ptr;
  // "a//a": the normal has the vertex's index.
  const std::size_t n = std::size_t(p - start);
  *p++ = '/';
  *p++ = '/';
  for (std::size_t k = 0; k < n; ++k) p[k] = start[k];
  return p + n;
}

}  // namespace

void write_obj(const std::string& path, const ExportData& data) {
  const TriMesh& mesh = data.mesh;
  AtomicFile file(path);
  BufferedWriter out(file);
  out.put("# " + data.generator + "\n");
  if (!data.unit.empty()) out.put("# unit: " + data.unit + "\n");
  if (!data.colors.empty()) out.put("# vertex colours: sRGB\n");
  for (const auto& line : data.params_lines) out.put(std::string("# ") + kParamsTag + line + "\n");
  out.put("o qjulia\n");
  const bool colored = !data.colors.empty();
  for (std::size_t v = 0; v < mesh.positions.size(); ++v) {
    char* p = out.reserve(256);
    char* q = p;
    *q++ = 'v';
    for (int i = 0; i < 3; ++i) q = put_float(q, mesh.positions[v][i]);
    if (colored)
      for (int i = 0; i < 3; ++i) q = put_float(q, linear_to_srgb(data.colors[v][i]));
    *q++ = '\n';
    out.advance(std::size_t(q - p));
  }
  for (const auto& n : data.normals) {
    char* p = out.reserve(128);
    char* q = p;
    *q++ = 'v';
    *q++ = 'n';
    for (int i = 0; i < 3; ++i) q = put_float(q, n[i]);
    *q++ = '\n';
    out.advance(std::size_t(q - p));
  }
  for (const auto& t : mesh.triangles) {
    char* p = out.reserve(128);
    char* q = p;
    *q++ = 'f';
    for (int i = 0; i < 3; ++i) q = put_index(q, t[i] + 1);
    *q++ = '\n';
    out.advance(std::size_t(q - p));
  }
  out.flush();
  file.commit();
}

}  // namespace qjulia::detail
