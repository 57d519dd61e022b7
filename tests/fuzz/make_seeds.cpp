// Writes the seed corpora of the fuzz targets: small meshes through the library's writers, and
// hand-made edge cases of each format. Usage: fuzz_seeds DIR (tests/fuzz/corpus); it writes
// DIR/<target>/<name> and overwrites what is there. The committed corpora were made by it.
#include <unistd.h>
#include <zip.h>

#include <array>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "qjulia/base/mesh.h"
#include "qjulia/field/params.h"
#include "qjulia/io/mesh_io.h"

namespace fs = std::filesystem;
using qjulia::TriMesh;

namespace {

fs::path g_root;

void put(const std::string& target, const std::string& name, const std::string& bytes) {
  const fs::path dir = g_root / target;
  fs::create_directories(dir);
  std::ofstream(dir / name, std::ios::binary) << bytes;
}

std::string slurp(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

TriMesh tetrahedron() {
  TriMesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  m.triangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  return m;
}

TriMesh colored_octahedron() {
  TriMesh m;
  m.positions = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  m.triangles = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4},
                 {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
  for (const auto& p : m.positions)
    m.colors.push_back({(p[0] + 1) / 2, (p[1] + 1) / 2, (p[2] + 1) / 2});
  return m;
}

const char* kParams = R"({"formula": "h^2+c", "constants": {"c": [0.1, -0.2, 0, 0]}})";

std::string base64(const std::string& in) {
  static const char* t = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  std::size_t i = 0;
  for (; i + 2 < in.size(); i += 3) {
    const unsigned v =
        (unsigned char)in[i] << 16 | (unsigned char)in[i + 1] << 8 | (unsigned char)in[i + 2];
    for (int k = 18; k >= 0; k -= 6) out += t[(v >> k) & 63];
  }
  if (i < in.size()) {
    unsigned v = (unsigned char)in[i] << 16;
    if (i + 1 < in.size()) v |= (unsigned char)in[i + 1] << 8;
    out += t[(v >> 18) & 63];
    out += t[(v >> 12) & 63];
    out += i + 1 < in.size() ? t[(v >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

/// The meshes through every writer; a .gltf with its .bin inlined as a data: URI.
void written_seeds(const fs::path& tmp) {
  struct Mesh {
    const char* name;
    TriMesh mesh;
    const char* params;
  };
  const Mesh meshes[] = {{"tetrahedron", tetrahedron(), ""},
                         {"octahedron_colored", colored_octahedron(), kParams}};
  const std::pair<const char*, const char*> targets[] = {
      {".ply", "ply_binary_le"}, {".obj", "obj"}, {".stl", "stl_binary"},
      {".glb", "glb"},           {".3mf", "3mf"}, {".gltf", "gltf"}};
  for (const auto& m : meshes)
    for (const auto& [ext, target] : targets) {
      const fs::path path = tmp / (std::string(m.name) + ext);
      qjulia::write_mesh(path.string(), m.mesh, {m.params, "mm", {}});
      std::string bytes = slurp(path);
      if (std::string(ext) == ".gltf") {
        const std::string uri = "\"" + std::string(m.name) + ".bin\"";
        const auto at = bytes.find(uri);
        bytes.replace(at, uri.size(),
                      "\"data:application/octet-stream;base64," +
                          base64(slurp(tmp / (std::string(m.name) + ".bin"))) + "\"");
      }
      put(target, std::string("written_") + m.name + ext, bytes);
    }
}

std::string u32(uint32_t v) { return std::string(reinterpret_cast<const char*>(&v), 4); }

std::string be(const void* p, std::size_t n) {
  std::string s(static_cast<const char*>(p), n);
  return std::string(s.rbegin(), s.rend());
}

/// The triangles as big-endian PLY face records: a Count 3, then three Index values.
template <class Count, class Index>
std::string be_faces(const TriMesh& m) {
  std::string out;
  for (const auto& f : m.triangles) {
    const Count n = 3;
    out += be(&n, sizeof n);
    for (uint32_t i : f) {
      const Index s = Index(i);
      out += be(&s, sizeof s);
    }
  }
  return out;
}

void ply_seeds() {
  put("ply_ascii", "triangle.ply",
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
      "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
      "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  put("ply_ascii", "quad_edge_element_crlf.ply",
      "ply\r\nformat ascii 1.0\r\ncomment params {\"a\": 1}\r\nelement vertex 4\r\n"
      "property double x\r\nproperty double y\r\nproperty double z\r\nproperty uchar red\r\n"
      "property uchar green\r\nproperty uchar blue\r\nelement face 1\r\n"
      "property list uchar uint vertex_index\r\nelement edge 1\r\nproperty int vertex1\r\n"
      "property int vertex2\r\nend_header\r\n0 0 0 255 0 0\r\n1 0 0 0 255 0\r\n"
      "1 1 0 0 0 255\r\n0 1 0 9 9 9\r\n4 0 1 2 3\r\n0 1\r\n");
  put("ply_ascii", "normals_list_in_vertex.ply",
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
      "property float z\nproperty float nx\nproperty float ny\nproperty float nz\n"
      "property list uchar float extra\nelement face 2\nproperty uchar flags\n"
      "property list ushort short vertex_indices\nend_header\n"
      "0 0 0 0 0 1 2 5 6\n1 0 0 0 0 1 0\n0 1 0 0 0 1 1 7\n1 3 0 1 2\n0 3 2 1 0\n");
  put("ply_ascii", "huge_count.ply",
      "ply\nformat ascii 1.0\nelement vertex 4000000000\nproperty float x\nproperty float y\n"
      "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
      "0 0 0\n");
  put("ply_ascii", "repeated_index.ply",
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
      "property float z\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n"
      "0 0 0\n1 0 0\n0 1 0\n3 0 1 1\n3 0 1 2\n");
  put("ply_ascii", "nonfinite.ply",
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
      "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
      "0 0 1e400\n1 0 nan\n0 1 0\n3 0 1 2\n");

  // Big endian, hand-made: the tetrahedron with int indices and uchar colours.
  const TriMesh t = tetrahedron();
  std::string body;
  for (const auto& p : t.positions) {
    for (float c : p) body += be(&c, 4);
    body += std::string("\x80\x40\x20", 3);
  }
  body += be_faces<uint8_t, int32_t>(t);
  put("ply_binary_be", "tetrahedron_colored.ply",
      "ply\nformat binary_big_endian 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
      "property float z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n"
      "element face 4\nproperty list uchar int vertex_indices\nend_header\n" +
          body);
  std::string dbody;
  for (const auto& p : t.positions)
    for (float c : p) {
      const double d = c;
      dbody += be(&d, 8);
    }
  dbody += be_faces<uint16_t, uint16_t>(t);
  put("ply_binary_be", "tetrahedron_double_ushort.ply",
      "ply\nformat binary_big_endian 1.0\nelement vertex 4\nproperty double x\n"
      "property double y\nproperty double z\nelement face 4\n"
      "property list ushort ushort vertex_indices\nend_header\n" +
          dbody);
  put("ply_binary_le", "huge_count.ply",
      "ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\nproperty float x\n"
      "property float y\nproperty float z\nelement face 1\n"
      "property list uchar int vertex_indices\nend_header\n" +
          std::string(40, '\0'));
}

void text_seeds() {
  put("obj", "quads_negative_vt_vn_crlf.obj",
      "# cube face\r\nv 0 0 0\r\nv 1 0 0\r\nv 1 1 0\r\nv 0 1 0\r\nvt 0 0\r\nvn 0 0 1\r\n"
      "f 1/1/1 2/1/1 3/1/1 4/1/1\r\nf -4 -2 -1\r\n");
  put("obj", "colors_groups.obj",
      "mtllib x.mtl\no a\ng b\nv 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 0 1 0 0 0 1\ns off\n"
      "usemtl m\nf 1 2 3\nl 1 2\n");
  put("obj", "bad_index.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\nf 1 2 3\n");
  put("stl_ascii", "two_triangles.stl",
      "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 1 1 0\n"
      "endloop\nendfacet\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 1 0\n"
      "vertex -0 1 0\nendloop\nendfacet\nendsolid t\n");
  put("stl_ascii", "degenerate_truncated.stl",
      "  solid x\n facet normal 0 0 0\n  outer loop\n   vertex 1 1 1\n   vertex 1 1 1\n"
      "   vertex 2 2 2\n  endloop\n endfacet\n facet\n vertex 0 0 0\n");
  std::string stl(80, ' ');
  stl += u32(1);
  const float tri[12] = {0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0};
  stl.append(reinterpret_cast<const char*>(tri), sizeof tri);
  stl += std::string(2, '\0');
  put("stl_binary", "one_triangle.stl", stl);
  put("stl_binary", "count_mismatch.stl", std::string(80, 'x') + u32(1000) + std::string(50, '\0'));
}

void gltf_seeds() {
  // A BIN chunk whose length counts its own 8-byte header too: tinygltf 2.7 checks it against
  // the GLB's length without the header and copies 8 bytes from past the end of the file.
  const std::string json = R"({"asset":{"version":"2.0"},"buffers":[{"byteLength":12}]})";
  std::string padded = json;
  while (padded.size() % 4) padded += ' ';
  std::string glb = u32(0x46546C67) + u32(2) + u32(uint32_t(20 + padded.size() + 8 + 4)) +
                    u32(uint32_t(padded.size())) + u32(0x4E4F534A) + padded;
  glb += u32(12) + u32(0x004E4942) + "data";
  put("glb", "bin_chunk_past_end.glb", glb);
  put("gltf", "file_uri_refused.gltf",
      R"({"asset":{"version":"2.0"},"buffers":[{"byteLength":12,"uri":"../../etc/passwd"}],)"
      R"("bufferViews":[{"buffer":0,"byteLength":12}],"accessors":[{"bufferView":0,)"
      R"("componentType":5126,"count":1,"type":"VEC3"}],"meshes":[{"primitives":[{)"
      R"("attributes":{"POSITION":0}}]}]})");
  put("gltf", "sparse_and_strides.gltf",
      R"({"asset":{"version":"2.0"},"buffers":[{"byteLength":36,)"
      R"("uri":"data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA"}],)"
      R"("bufferViews":[{"buffer":0,"byteLength":36,"byteStride":12}],)"
      R"("accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3"},)"
      R"({"componentType":5126,"count":3,"type":"VEC3","sparse":{"count":1,)"
      R"("indices":{"bufferView":0,"componentType":5125},"values":{"bufferView":0}}}],)"
      R"("meshes":[{"primitives":[{"attributes":{"POSITION":0}},{"attributes":{"POSITION":1}},)"
      R"({"mode":1,"attributes":{"POSITION":0}}]}]})");
}

/// A zip of `entries` (name, contents), deflated, written with libzip.
std::string zip_of(const fs::path& tmp,
                   const std::vector<std::pair<std::string, std::string>>& entries) {
  const fs::path path = tmp / "archive.zip";
  int err = 0;
  zip_t* z = zip_open(path.c_str(), ZIP_CREATE | ZIP_TRUNCATE, &err);
  for (const auto& [name, data] : entries) {
    zip_source_t* src = zip_source_buffer(z, data.data(), data.size(), 0);
    const zip_int64_t i = zip_file_add(z, name.c_str(), src, ZIP_FL_OVERWRITE);
    zip_set_file_compression(z, zip_uint64_t(i), ZIP_CM_DEFLATE, 9);
  }
  zip_close(z);
  return slurp(path);
}

void threemf_seeds(const fs::path& tmp) {
  const std::string types =
      R"(<?xml version="1.0" encoding="UTF-8"?><Types xmlns="http://schemas.openxmlformats.org/package/2006/content-types"><Default Extension="rels" ContentType="application/vnd.openxmlformats-package.relationships+xml"/><Default Extension="model" ContentType="application/vnd.ms-package.3dmanufacturing-3dmodel+xml"/></Types>)";
  const std::string rels =
      R"(<?xml version="1.0" encoding="UTF-8"?><Relationships xmlns="http://schemas.openxmlformats.org/package/2006/relationships"><Relationship Target="/3D/3dmodel.model" Id="rel0" Type="http://schemas.microsoft.com/3dmanufacturing/2013/01/3dmodel"/></Relationships>)";
  const std::string model_head =
      R"(<?xml version="1.0" encoding="UTF-8"?><model unit="millimeter" xmlns="http://schemas.microsoft.com/3dmanufacturing/core/2015/02"><resources><object id="1" type="model"><mesh><vertices>)";
  const std::string model_tail =
      R"(<vertex x="0" y="0" z="0"/><vertex x="1" y="0" z="0"/><vertex x="0" y="1" z="0"/></vertices><triangles><triangle v1="0" v2="1" v3="2"/><triangle v1="0" v2="1" v3="7"/></triangles></mesh></object></resources><build><item objectid="1"/></build></model>)";
  put("3mf", "hand_made_index_out_of_range.3mf",
      zip_of(tmp, {{"[Content_Types].xml", types},
                   {"_rels/.rels", rels},
                   {"3D/3dmodel.model", model_head + model_tail}}));
  // Two megabytes of blanks: refused (more than 100 times the archive's size).
  put("3mf", "bomb.3mf",
      zip_of(tmp, {{"[Content_Types].xml", types},
                   {"_rels/.rels", rels},
                   {"3D/3dmodel.model", model_head + std::string(2 << 20, ' ') + model_tail}}));
  const std::string written = slurp(g_root / "3mf" / "written_tetrahedron.3mf");
  put("3mf", "truncated.3mf", written.substr(0, written.size() / 2));
}

void params_seeds() {
  for (const auto& name : qjulia::preset_names())
    put("params", name + ".json", qjulia::params_to_json(qjulia::preset(name)));
  put("params", "empty_object.json", "{}");
  put("params", "out_of_range.json", R"({"resolution": 1e400, "iterations": -1})");
  put("params", "nan_bailout.json", R"({"bailout": "nan", "bounds": [[0,0,0],[0,0,0]]})");
  put("params", "unknown_key.json", R"({"formula": "h^2+c", "colour": "basin"})");
  put("params", "real_power.json",
      R"j({"formula": "exp(h)^0.5 + sqrt(c)", "constants": {"c": 0.25}})j");
}

void formula_seeds() {
  put("formula", "analytic", "exp(h) + log(h) * sqrt(c) - sin(h)/cos(h) + tan(p)");
  put("formula", "hyperbolic", "sinh(h)^0.5 + cosh(q) * tanh(h^-1.5)");
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: fuzz_seeds DIR\n";
    return 2;
  }
  g_root = argv[1];
  const fs::path tmp =
      fs::temp_directory_path() / ("qjulia_fuzz_seeds_" + std::to_string(::getpid()));
  fs::create_directories(tmp);
  written_seeds(tmp);
  threemf_seeds(tmp);
  fs::remove_all(tmp);
  ply_seeds();
  text_seeds();
  gltf_seeds();
  params_seeds();
  formula_seeds();
  return 0;
}
