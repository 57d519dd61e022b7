// Wavefront OBJ writer: `v x y z [r g b]`, `vn`, `f a//a b//b c//c`, parameters as comments.
#include <tbb/parallel_for.h>

#include <charconv>
#include <functional>

#include "qjulia/base/atomic_file.h"
#include "io/formats.h"

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

/// Formats lines [0, count) with `line(i, out) -> end` (at most `max_len` bytes each) in
/// parallel blocks and writes them in order; memory stays bounded by one batch of blocks.
void write_lines(BufferedWriter& out, std::size_t count, std::size_t max_len,
                 const std::function<char*(std::size_t, char*)>& line) {
  constexpr std::size_t kBlock = 32768;
  constexpr std::size_t kBatch = 16;
  std::vector<std::string> blocks(kBatch);
  for (std::size_t first = 0; first < count; first += kBlock * kBatch) {
    const std::size_t nblocks = std::min(kBatch, (count - first + kBlock - 1) / kBlock);
    tbb::parallel_for(std::size_t(0), nblocks, [&](std::size_t b) {
      const std::size_t begin = first + b * kBlock;
      const std::size_t end = std::min(count, begin + kBlock);
      std::string& s = blocks[b];
      s.resize((end - begin) * max_len);
      char* p = s.data();
      for (std::size_t i = begin; i < end; ++i) p = line(i, p);
      s.resize(std::size_t(p - s.data()));
    });
    for (std::size_t b = 0; b < nblocks; ++b) out.put(blocks[b]);
  }
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
  write_lines(out, mesh.positions.size(), 256, [&](std::size_t v, char* q) {
    *q++ = 'v';
    for (int i = 0; i < 3; ++i) q = put_float(q, mesh.positions[v][i]);
    if (colored)
      for (int i = 0; i < 3; ++i) q = put_float(q, linear_to_srgb(data.colors[v][i]));
    *q++ = '\n';
    return q;
  });
  write_lines(out, data.normals.size(), 128, [&](std::size_t v, char* q) {
    *q++ = 'v';
    *q++ = 'n';
    for (int i = 0; i < 3; ++i) q = put_float(q, data.normals[v][i]);
    *q++ = '\n';
    return q;
  });
  write_lines(out, mesh.triangles.size(), 128, [&](std::size_t f, char* q) {
    *q++ = 'f';
    for (int i = 0; i < 3; ++i) q = put_index(q, mesh.triangles[f][i] + 1);
    *q++ = '\n';
    return q;
  });
  out.flush();
  file.commit();
}

}  // namespace qjulia::detail
