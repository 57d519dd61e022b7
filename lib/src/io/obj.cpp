// Wavefront OBJ. Writer: `v x y z [r g b]`, `vn`, `f a//a b//b c//c`, the parameters as
// comments. Reader: v (with optional colours), vn, f (polygons fanned, v/vt/vn, negative
// indices); everything else (vt, o, g, s, usemtl, mtllib, l, ...) is not part of the mesh.
#include <tbb/parallel_for.h>

#include <algorithm>
#include <charconv>
#include <functional>

#include "io/formats.h"
#include "io/text.h"
#include "qjulia/base/atomic_file.h"

namespace qjulia::detail {

// ---------------------------------------------------------------------------------- writer

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
  AtomicFile file(path, data.cancel);
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

// ---------------------------------------------------------------------------------- reader

namespace {

/// The arrays of an OBJ file as it is read.
struct ObjState {
  TriMesh mesh;
  std::vector<std::array<float, 3>> vn;
  std::vector<std::array<float, 3>> colors;
  std::vector<int64_t> vertex_normal;  // vn index per vertex, -1 none
  bool all_colored = true;
  std::vector<long long> poly, poly_n;  // the face being read: vertex and vn indices
};

void read_vertex(LineCursor& c, const Lines& lines, ObjState& s, ReadContext& ctx) {
  std::array<float, 3> v;
  for (auto& x : v)
    if (!c.number(x)) ctx.fail(lines.where() + "expected three numbers after 'v'");
  float extra[4];
  int n = 0;
  while (n < 4 && !c.at_end()) {
    if (!c.number(extra[n])) ctx.fail(lines.where() + "expected a number");
    ++n;
  }
  if (n >= 3) {
    push_charged(s.colors,
                 {srgb_to_linear(extra[0]), srgb_to_linear(extra[1]), srgb_to_linear(extra[2])},
                 ctx, "vertex colours");
  } else {
    s.all_colored = false;
  }
  push_charged(s.mesh.positions, v, ctx, "vertex positions");
}

/// One "v[/vt[/vn]]" of a face: the 0-based vertex and vn indices (-1: no vn).
void read_face_vertex(std::string_view w, const Lines& lines, ObjState& s, ReadContext& ctx) {
  long long vi = 0, ni = 0;
  const char* p = w.data();
  const char* end = p + w.size();
  auto r = std::from_chars(p, end, vi);
  if (r.ec != std::errc() || vi == 0)
    ctx.fail(lines.where() + "bad face vertex '" + std::string(w) + "'");
  p = r.ptr;
  if (p < end && *p == '/') {
    ++p;
    while (p < end && *p != '/') ++p;  // texture coordinate: ignored
    if (p < end && *p == '/') {
      ++p;
      r = std::from_chars(p, end, ni);
      if (r.ec != std::errc())
        ctx.fail(lines.where() + "bad face normal index '" + std::string(w) + "'");
      p = r.ptr;
    }
  }
  if (p != end) ctx.fail(lines.where() + "bad face vertex '" + std::string(w) + "'");
  const long long nv = (long long)s.mesh.positions.size();
  const long long v = vi > 0 ? vi - 1 : nv + vi;
  if (v < 0 || v >= nv) {
    ctx.fail(lines.where() + "vertex index " + std::to_string(vi) + " out of range (" +
             std::to_string(nv) + " vertices so far)");
  }
  long long n = -1;
  if (ni != 0) {
    const long long nvn = (long long)s.vn.size();
    n = ni > 0 ? ni - 1 : nvn + ni;
    if (n < 0 || n >= nvn)
      ctx.fail(lines.where() + "normal index " + std::to_string(ni) + " out of range");
  }
  s.poly.push_back(v);
  s.poly_n.push_back(n);
}

void read_face(LineCursor& c, const Lines& lines, ObjState& s, ReadContext& ctx) {
  s.poly.clear();
  s.poly_n.clear();
  while (!c.at_end()) read_face_vertex(c.word(), lines, s, ctx);
  if (s.poly.size() < 3) ctx.fail(lines.where() + "a face needs at least 3 vertices");
  if (s.vertex_normal.size() < s.mesh.positions.size()) {
    reserve_charged(s.vertex_normal, s.mesh.positions.size(), ctx, "vertex normal indices");
    s.vertex_normal.resize(s.mesh.positions.size(), -1);
  }
  for (std::size_t k = 0; k < s.poly.size(); ++k)
    if (s.poly_n[k] >= 0) s.vertex_normal[s.poly[k]] = s.poly_n[k];
  for (std::size_t k = 1; k + 1 < s.poly.size(); ++k) {
    push_charged(s.mesh.triangles,
                 {uint32_t(s.poly[0]), uint32_t(s.poly[k]), uint32_t(s.poly[k + 1])}, ctx,
                 "triangles");
  }
}

/// Per-vertex normals from the vn the faces name, when every vertex has one; colours when
/// every vertex has them.
void assign_attributes(ObjState& s) {
  TriMesh& mesh = s.mesh;
  if (s.all_colored && s.colors.size() == mesh.positions.size()) mesh.colors = std::move(s.colors);
  s.vertex_normal.resize(mesh.positions.size(), -1);
  // Vertices no face gives a normal (unreferenced ones): the vn of the same number, when the
  // file has one vn per v (as ours do).
  if (s.vn.size() == mesh.positions.size())
    for (std::size_t v = 0; v < s.vertex_normal.size(); ++v)
      if (s.vertex_normal[v] < 0) s.vertex_normal[v] = int64_t(v);
  if (!s.vn.empty() && std::all_of(s.vertex_normal.begin(), s.vertex_normal.end(),
                                   [](int64_t n) { return n >= 0; })) {
    mesh.normals.resize(mesh.positions.size());
    for (std::size_t v = 0; v < mesh.positions.size(); ++v)
      mesh.normals[v] = s.vn[s.vertex_normal[v]];
  }
}

}  // namespace

TriMesh read_obj(std::string_view text, ReadContext& ctx) {
  ObjState s;
  Lines lines(text);
  LineCursor c{nullptr, nullptr};
  while (lines.next(c)) {
    c.skip();
    if (c.p >= c.end || *c.p == '#') continue;
    const std::string_view key = c.word();
    if (key == "v") {
      read_vertex(c, lines, s, ctx);
    } else if (key == "vn") {
      std::array<float, 3> n;
      for (auto& x : n)
        if (!c.number(x)) ctx.fail(lines.where() + "expected three numbers after 'vn'");
      push_charged(s.vn, n, ctx, "normals");
    } else if (key == "f") {
      read_face(c, lines, s, ctx);
    }
  }
  if (s.mesh.triangles.empty()) ctx.fail("no faces found (not an OBJ mesh?)");
  ctx.charge(s.mesh.positions.size(), 12 + 12, "vertex normals and colours");
  assign_attributes(s);
  return std::move(s.mesh);
}

std::string read_obj_params(std::string_view text) { return comment_params(text, "# ", false); }

}  // namespace qjulia::detail
