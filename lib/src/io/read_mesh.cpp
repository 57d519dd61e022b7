// Readers of OBJ, PLY (ascii, binary little/big endian) and STL (binary, ascii). Own parsers:
// a whole file is read at once and parsed in place with std::from_chars.
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstring>

#include "io/formats.h"
#include "qjulia/base/error.h"

namespace qjulia::detail {
namespace {

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r'; }

/// A cursor over one line of text.
struct LineCursor {
  const char* p;
  const char* end;
  void skip() {
    while (p < end && is_space(*p)) ++p;
  }
  bool at_end() {
    skip();
    return p >= end;
  }
  bool number(float& out) {
    skip();
    if (p < end && *p == '+') ++p;
    const auto r = std::from_chars(p, end, out);
    if (r.ec == std::errc::result_out_of_range) {
      // Denormals and overflow: let strtod decide (from_chars refuses them).
      char* e = nullptr;
      out = std::strtof(std::string(p, std::size_t(std::min<std::ptrdiff_t>(end - p, 64))).c_str(),
                        &e);
      p = r.ptr;
      return true;
    }
    if (r.ec != std::errc()) return false;
    p = r.ptr;
    return true;
  }
  bool number(double& out) {
    skip();
    if (p < end && *p == '+') ++p;
    const auto r = std::from_chars(p, end, out);
    if (r.ec != std::errc() && r.ec != std::errc::result_out_of_range) return false;
    p = r.ptr;
    return true;
  }
  std::string_view word() {
    skip();
    const char* s = p;
    while (p < end && !is_space(*p)) ++p;
    return {s, std::size_t(p - s)};
  }
};

std::string line_no(std::size_t n) { return "line " + std::to_string(n) + ": "; }

}  // namespace

// ---------------------------------------------------------------------------------- OBJ

TriMesh read_obj(const std::string& path) {
  const std::string text = read_file(path);
  TriMesh mesh;
  std::vector<std::array<float, 3>> vn;
  std::vector<std::array<float, 3>> colors;
  std::vector<int64_t> vertex_normal;  // vn index per vertex, -1 none
  bool all_colored = true;
  std::vector<long long> poly;
  std::vector<long long> poly_n;
  const char* p = text.data();
  const char* const end = p + text.size();
  std::size_t line = 0;
  while (p < end) {
    ++line;
    const char* eol = static_cast<const char*>(std::memchr(p, '\n', std::size_t(end - p)));
    if (!eol) eol = end;
    LineCursor c{p, eol};
    p = eol + 1;
    c.skip();
    if (c.p >= eol || *c.p == '#') continue;
    const std::string_view key = c.word();
    if (key == "v") {
      std::array<float, 3> v;
      for (auto& x : v)
        if (!c.number(x)) fail(path, line_no(line) + "expected three numbers after 'v'");
      float extra[4];
      int n = 0;
      while (n < 4 && !c.at_end()) {
        if (!c.number(extra[n])) fail(path, line_no(line) + "expected a number");
        ++n;
      }
      if (n >= 3) {
        colors.push_back(
            {srgb_to_linear(extra[0]), srgb_to_linear(extra[1]), srgb_to_linear(extra[2])});
      } else {
        all_colored = false;
      }
      mesh.positions.push_back(v);
    } else if (key == "vn") {
      std::array<float, 3> n;
      for (auto& x : n)
        if (!c.number(x)) fail(path, line_no(line) + "expected three numbers after 'vn'");
      vn.push_back(n);
    } else if (key == "f") {
      poly.clear();
      poly_n.clear();
      while (!c.at_end()) {
        const std::string_view w = c.word();
        long long vi = 0, ni = 0;
        const char* s = w.data();
        const char* we = s + w.size();
        auto r = std::from_chars(s, we, vi);
        if (r.ec != std::errc() || vi == 0)
          fail(path, line_no(line) + "bad face vertex '" + std::string(w) + "'");
        s = r.ptr;
        if (s < we && *s == '/') {
          ++s;
          while (s < we && *s != '/') ++s;  // texture coordinate: ignored
          if (s < we && *s == '/') {
            ++s;
            r = std::from_chars(s, we, ni);
            if (r.ec != std::errc())
              fail(path, line_no(line) + "bad face normal index '" + std::string(w) + "'");
            s = r.ptr;
          }
        }
        if (s != we) fail(path, line_no(line) + "bad face vertex '" + std::string(w) + "'");
        const long long nv = (long long)mesh.positions.size();
        const long long v = vi > 0 ? vi - 1 : nv + vi;
        if (v < 0 || v >= nv) {
          fail(path, line_no(line) + "vertex index " + std::to_string(vi) + " out of range (" +
                         std::to_string(nv) + " vertices so far)");
        }
        long long n = -1;
        if (ni != 0) {
          n = ni > 0 ? ni - 1 : (long long)vn.size() + ni;
          if (n < 0 || n >= (long long)vn.size())
            fail(path, line_no(line) + "normal index " + std::to_string(ni) + " out of range");
        }
        poly.push_back(v);
        poly_n.push_back(n);
      }
      if (poly.size() < 3) fail(path, line_no(line) + "a face needs at least 3 vertices");
      if (vertex_normal.size() < mesh.positions.size())
        vertex_normal.resize(mesh.positions.size(), -1);
      for (std::size_t k = 0; k < poly.size(); ++k)
        if (poly_n[k] >= 0) vertex_normal[poly[k]] = poly_n[k];
      for (std::size_t k = 1; k + 1 < poly.size(); ++k) {
        mesh.triangles.push_back({uint32_t(poly[0]), uint32_t(poly[k]), uint32_t(poly[k + 1])});
      }
    }
    // vt, o, g, s, usemtl, mtllib, l, ...: not part of the mesh we read.
  }
  if (mesh.triangles.empty()) fail(path, "no faces found (not an OBJ mesh?)");
  for (const auto& v : mesh.positions)
    if (!std::isfinite(v[0]) || !std::isfinite(v[1]) || !std::isfinite(v[2]))
      fail(path, "a vertex position is not finite");
  if (all_colored && colors.size() == mesh.positions.size()) mesh.colors = std::move(colors);
  vertex_normal.resize(mesh.positions.size(), -1);
  // Vertices no face gives a normal (unreferenced ones): the vn of the same number, when the
  // file has one vn per v (as ours do).
  if (vn.size() == mesh.positions.size())
    for (std::size_t v = 0; v < vertex_normal.size(); ++v)
      if (vertex_normal[v] < 0) vertex_normal[v] = int64_t(v);
  if (!vn.empty() &&
      std::all_of(vertex_normal.begin(), vertex_normal.end(), [](int64_t n) { return n >= 0; })) {
    mesh.normals.resize(mesh.positions.size());
    for (std::size_t v = 0; v < mesh.positions.size(); ++v) mesh.normals[v] = vn[vertex_normal[v]];
  }
  return mesh;
}

namespace {

std::string read_comment_params(const std::string& path, const std::string& comment_prefix,
                                bool header_only) {
  const std::string text = read_file(path);
  const std::string prefix = comment_prefix + kParamsTag;
  std::string out;
  std::size_t pos = 0;
  while (pos < text.size()) {
    std::size_t eol = text.find('\n', pos);
    if (eol == std::string::npos) eol = text.size();
    std::string_view l(text.data() + pos, eol - pos);
    if (!l.empty() && l.back() == '\r') l.remove_suffix(1);
    if (l.substr(0, prefix.size()) == prefix) {
      out.append(l.substr(prefix.size()));
      out += '\n';
    } else if (header_only && l == "end_header") {
      break;
    } else if (!header_only && !l.empty() && l[0] != '#') {
      break;  // the comment block is at the top
    }
    pos = eol + 1;
  }
  if (!out.empty()) out.pop_back();
  return out;
}

}  // namespace

std::string read_obj_params(const std::string& path) {
  return read_comment_params(path, "# ", false);
}
std::string read_ply_params(const std::string& path) {
  return read_comment_params(path, "comment ", true);
}

// ---------------------------------------------------------------------------------- PLY

namespace {

enum class PlyType { kI8, kU8, kI16, kU16, kI32, kU32, kF32, kF64 };

bool ply_type(std::string_view s, PlyType& t) {
  if (s == "char" || s == "int8")
    t = PlyType::kI8;
  else if (s == "uchar" || s == "uint8")
    t = PlyType::kU8;
  else if (s == "short" || s == "int16")
    t = PlyType::kI16;
  else if (s == "ushort" || s == "uint16")
    t = PlyType::kU16;
  else if (s == "int" || s == "int32")
    t = PlyType::kI32;
  else if (s == "uint" || s == "uint32")
    t = PlyType::kU32;
  else if (s == "float" || s == "float32")
    t = PlyType::kF32;
  else if (s == "double" || s == "float64")
    t = PlyType::kF64;
  else
    return false;
  return true;
}

std::size_t type_size(PlyType t) {
  switch (t) {
    case PlyType::kI8:
    case PlyType::kU8:
      return 1;
    case PlyType::kI16:
    case PlyType::kU16:
      return 2;
    case PlyType::kI32:
    case PlyType::kU32:
    case PlyType::kF32:
      return 4;
    case PlyType::kF64:
      return 8;
  }
  return 0;
}

struct PlyProperty {
  std::string name;
  PlyType type = PlyType::kF32;
  bool list = false;
  PlyType count_type = PlyType::kU8;
};

struct PlyElement {
  std::string name;
  std::size_t count = 0;
  std::vector<PlyProperty> props;
};

/// Reads values from the body: binary (either endianness) or ASCII tokens.
class PlyBody {
 public:
  PlyBody(const std::string& path, const char* p, const char* end, int format)
      : path_(path), p_(p), end_(end), format_(format) {}

  double read(PlyType t) {
    if (format_ == 0) return read_ascii();
    const std::size_t n = type_size(t);
    if (std::size_t(end_ - p_) < n) fail(path_, "the file is truncated (data ends early)");
    unsigned char b[8];
    std::memcpy(b, p_, n);
    p_ += n;
    if (format_ == 2) std::reverse(b, b + n);
    switch (t) {
      case PlyType::kI8:
        return double(int8_t(b[0]));
      case PlyType::kU8:
        return double(b[0]);
      case PlyType::kI16: {
        int16_t v;
        std::memcpy(&v, b, 2);
        return v;
      }
      case PlyType::kU16: {
        uint16_t v;
        std::memcpy(&v, b, 2);
        return v;
      }
      case PlyType::kI32: {
        int32_t v;
        std::memcpy(&v, b, 4);
        return v;
      }
      case PlyType::kU32: {
        uint32_t v;
        std::memcpy(&v, b, 4);
        return v;
      }
      case PlyType::kF32: {
        float v;
        std::memcpy(&v, b, 4);
        return v;
      }
      case PlyType::kF64: {
        double v;
        std::memcpy(&v, b, 8);
        return v;
      }
    }
    return 0;
  }
  float read_float(PlyType t) {
    if (t == PlyType::kF32 && format_ == 1) {
      if (std::size_t(end_ - p_) < 4) fail(path_, "the file is truncated (data ends early)");
      float v;
      std::memcpy(&v, p_, 4);
      p_ += 4;
      return v;
    }
    return float(read(t));
  }

 private:
  double read_ascii() {
    while (p_ < end_ && (is_space(*p_) || *p_ == '\n')) ++p_;
    if (p_ >= end_) fail(path_, "the file is truncated (data ends early)");
    double v;
    const auto r = std::from_chars(p_, end_, v);
    if (r.ec != std::errc() && r.ec != std::errc::result_out_of_range) {
      fail(path_, "expected a number in the data, found '" +
                      std::string(p_, std::min<std::size_t>(10, std::size_t(end_ - p_))) + "'");
    }
    p_ = r.ptr;
    return v;
  }
  const std::string& path_;
  const char* p_;
  const char* end_;
  int format_;  // 0 ascii, 1 binary LE, 2 binary BE
};

}  // namespace

TriMesh read_ply(const std::string& path) {
  const std::string text = read_file(path);
  if (text.compare(0, 4, "ply\n") != 0 && text.compare(0, 5, "ply\r\n") != 0)
    fail(path, "not a PLY file (no 'ply' magic)");
  std::size_t pos = 0;
  int format = -1;
  std::vector<PlyElement> elements;
  bool ended = false;
  std::size_t line = 0;
  while (pos < text.size()) {
    ++line;
    std::size_t eol = text.find('\n', pos);
    if (eol == std::string::npos) fail(path, "the header is truncated (no end_header)");
    LineCursor c{text.data() + pos, text.data() + eol};
    pos = eol + 1;
    const std::string_view key = c.word();
    if (key == "end_header") {
      ended = true;
      break;
    }
    if (key == "format") {
      const auto f = c.word();
      if (f == "ascii")
        format = 0;
      else if (f == "binary_little_endian")
        format = 1;
      else if (f == "binary_big_endian")
        format = 2;
      else
        fail(path, line_no(line) + "unknown format '" + std::string(f) + "'");
    } else if (key == "element") {
      PlyElement e;
      e.name = std::string(c.word());
      const auto n = c.word();
      const auto r = std::from_chars(n.data(), n.data() + n.size(), e.count);
      if (r.ec != std::errc() || e.name.empty()) fail(path, line_no(line) + "bad element line");
      elements.push_back(e);
    } else if (key == "property") {
      if (elements.empty()) fail(path, line_no(line) + "property before any element");
      PlyProperty prop;
      auto t = c.word();
      if (t == "list") {
        prop.list = true;
        if (!ply_type(c.word(), prop.count_type)) fail(path, line_no(line) + "bad list count type");
        t = c.word();
      }
      if (!ply_type(t, prop.type))
        fail(path, line_no(line) + "unknown property type '" + std::string(t) + "'");
      prop.name = std::string(c.word());
      elements.back().props.push_back(prop);
    } else if (key == "comment" || key == "obj_info" || key == "ply" || key.empty()) {
    } else {
      fail(path, line_no(line) + "unexpected header line '" + std::string(key) + "'");
    }
  }
  if (!ended) fail(path, "the header is truncated (no end_header)");
  if (format < 0) fail(path, "the header has no format line");

  // Sanity before allocating: the body must hold at least the fixed-size part (binary), or
  // two characters per value (ascii: a digit and a separator).
  if (format == 0) {
    std::size_t need = 0;
    for (const auto& e : elements) {
      if (e.props.size() && e.count > (text.size() - pos) / (2 * e.props.size()) + 1) {
        fail(path,
             "the file is truncated (element '" + e.name + "' needs more data than the file has)");
      }
      need += 2 * e.props.size() * e.count;
    }
    if (need > text.size() - pos + 1) fail(path, "the file is truncated (data ends early)");
  } else {
    std::size_t need = 0;
    for (const auto& e : elements) {
      std::size_t rec = 0;
      for (const auto& pr : e.props) rec += pr.list ? type_size(pr.count_type) : type_size(pr.type);
      if (rec && e.count > (text.size() - pos) / rec + 1)
        fail(path,
             "the file is truncated (element '" + e.name + "' needs more data than the file has)");
      need += rec * e.count;
    }
    if (need > text.size() - pos)
      fail(path, "the file is truncated (" + std::to_string(text.size() - pos) +
                     " data bytes, at least " + std::to_string(need) + " needed)");
  }

  TriMesh mesh;
  PlyBody body(path, text.data() + pos, text.data() + text.size(), format);
  bool have_vertices = false, have_faces = false;
  for (const auto& e : elements) {
    if (e.name == "vertex") {
      if (have_vertices) fail(path, "two vertex elements");
      have_vertices = true;
      int ix = -1, iy = -1, iz = -1, inx = -1, iny = -1, inz = -1, ir = -1, ig = -1, ib = -1;
      for (int i = 0; i < int(e.props.size()); ++i) {
        const auto& n = e.props[i].name;
        if (e.props[i].list) continue;
        if (n == "x")
          ix = i;
        else if (n == "y")
          iy = i;
        else if (n == "z")
          iz = i;
        else if (n == "nx")
          inx = i;
        else if (n == "ny")
          iny = i;
        else if (n == "nz")
          inz = i;
        else if (n == "red" || n == "r")
          ir = i;
        else if (n == "green" || n == "g")
          ig = i;
        else if (n == "blue" || n == "b")
          ib = i;
      }
      if (ix < 0 || iy < 0 || iz < 0) fail(path, "the vertex element has no x, y, z");
      const bool normals = inx >= 0 && iny >= 0 && inz >= 0;
      const bool colors = ir >= 0 && ig >= 0 && ib >= 0;
      const bool byte_color = colors && e.props[ir].type == PlyType::kU8;
      mesh.positions.resize(e.count);
      if (normals) mesh.normals.resize(e.count);
      if (colors) mesh.colors.resize(e.count);
      float vals[64];
      std::vector<float> big;
      float* row = e.props.size() <= 64 ? vals : (big.resize(e.props.size()), big.data());
      for (std::size_t v = 0; v < e.count; ++v) {
        for (std::size_t i = 0; i < e.props.size(); ++i) {
          const auto& pr = e.props[i];
          if (pr.list) {
            const auto n = std::size_t(body.read(pr.count_type));
            for (std::size_t k = 0; k < n; ++k) body.read(pr.type);
            row[i] = 0;
          } else {
            row[i] = body.read_float(pr.type);
          }
        }
        mesh.positions[v] = {row[ix], row[iy], row[iz]};
        if (normals) mesh.normals[v] = {row[inx], row[iny], row[inz]};
        if (colors) {
          const float s = byte_color ? 1.0f / 255.0f : 1.0f;
          mesh.colors[v] = {srgb_to_linear(row[ir] * s), srgb_to_linear(row[ig] * s),
                            srgb_to_linear(row[ib] * s)};
        }
      }
    } else if (e.name == "face") {
      have_faces = true;
      int iv = -1;
      for (int i = 0; i < int(e.props.size()); ++i)
        if (e.props[i].list &&
            (e.props[i].name == "vertex_indices" || e.props[i].name == "vertex_index"))
          iv = i;
      if (iv < 0) fail(path, "the face element has no vertex_indices list");
      mesh.triangles.reserve(e.count);
      std::vector<uint32_t> poly;
      for (std::size_t f = 0; f < e.count; ++f) {
        for (int i = 0; i < int(e.props.size()); ++i) {
          const auto& pr = e.props[i];
          if (!pr.list) {
            body.read(pr.type);
            continue;
          }
          const double nd = body.read(pr.count_type);
          if (!(nd >= 0) || nd > 1e6)
            fail(path, "face " + std::to_string(f) + " has a bad vertex count");
          const auto n = std::size_t(nd);
          if (i != iv) {
            for (std::size_t k = 0; k < n; ++k) body.read(pr.type);
            continue;
          }
          poly.resize(n);
          for (std::size_t k = 0; k < n; ++k) {
            const double idx = body.read(pr.type);
            if (!(idx >= 0) || idx >= double(mesh.positions.size()) || !have_vertices) {
              fail(path, "face " + std::to_string(f) + " has vertex index " +
                             std::to_string((long long)idx) + " out of range (" +
                             std::to_string(mesh.positions.size()) + " vertices)");
            }
            poly[k] = uint32_t(idx);
          }
          if (n < 3) fail(path, "face " + std::to_string(f) + " has fewer than 3 vertices");
          for (std::size_t k = 1; k + 1 < n; ++k)
            mesh.triangles.push_back({poly[0], poly[k], poly[k + 1]});
        }
      }
    } else {
      for (std::size_t r = 0; r < e.count; ++r)
        for (const auto& pr : e.props) {
          if (pr.list) {
            const double nd = body.read(pr.count_type);
            if (!(nd >= 0) || nd > 1e9)
              fail(path, "element '" + e.name + "' has a bad list length");
            for (std::size_t k = 0; k < std::size_t(nd); ++k) body.read(pr.type);
          } else {
            body.read(pr.type);
          }
        }
    }
  }
  if (!have_vertices) fail(path, "no vertex element");
  if (!have_faces || mesh.triangles.empty()) fail(path, "no faces (a point cloud is not a mesh)");
  for (const auto& v : mesh.positions)
    if (!std::isfinite(v[0]) || !std::isfinite(v[1]) || !std::isfinite(v[2]))
      fail(path, "a vertex position is not finite");
  return mesh;
}

// ---------------------------------------------------------------------------------- STL

TriMesh read_stl(const std::string& path) {
  const std::string data = read_file(path);
  std::vector<std::array<float, 3>> corners;
  uint32_t count = 0;
  if (data.size() >= 84) std::memcpy(&count, data.data() + 80, 4);
  const bool binary = data.size() >= 84 && 84 + 50ull * count == data.size();
  std::size_t first = data.find_first_not_of(" \t\r\n");
  const bool ascii = !binary && first != std::string::npos && data.compare(first, 5, "solid") == 0;
  if (binary) {
    corners.resize(std::size_t(count) * 3);
    const char* p = data.data() + 84;
    for (std::size_t t = 0; t < count; ++t, p += 50) std::memcpy(corners[3 * t].data(), p + 12, 36);
  } else if (ascii) {
    const char* p = data.data() + first;
    const char* const end = data.data() + data.size();
    std::size_t line = 0;
    while (p < end) {
      ++line;
      const char* eol = static_cast<const char*>(std::memchr(p, '\n', std::size_t(end - p)));
      if (!eol) eol = end;
      LineCursor c{p, eol};
      p = eol + 1;
      if (c.word() != "vertex") continue;
      std::array<float, 3> v;
      for (auto& x : v)
        if (!c.number(x)) fail(path, line_no(line) + "expected three numbers after 'vertex'");
      corners.push_back(v);
    }
    if (corners.size() % 3 != 0)
      fail(path, "the ASCII STL is truncated (vertex count not a multiple of 3)");
  } else if (data.size() < 84) {
    fail(path, "too short to be an STL file (" + std::to_string(data.size()) + " bytes)");
  } else {
    fail(path, "truncated or not an STL file: the binary header says " + std::to_string(count) +
                   " triangles (" + std::to_string(84 + 50ull * count) + " bytes), the file has " +
                   std::to_string(data.size()) + " bytes");
  }
  if (corners.empty()) fail(path, "the STL file has no triangles");
  for (const auto& v : corners)
    if (!std::isfinite(v[0]) || !std::isfinite(v[1]) || !std::isfinite(v[2]))
      fail(path, "a vertex position is not finite");
  TriMesh mesh;
  weld_corners(corners, mesh);
  return mesh;
}

}  // namespace qjulia::detail
