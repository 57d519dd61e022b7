// Round trips through every writer and reader, and the failure paths of write_mesh/read_mesh.
#include <gtest/gtest.h>
#include <tbb/task_arena.h>
#include <zip.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <random>
#include <set>

#include "io/formats.h"
#include "io_fixtures.h"
#include "qjulia/base/error.h"
#include "qjulia/io/mesh_io.h"
#include "test_meshes.h"

namespace fs = std::filesystem;
using qjulia::InvalidInput;
using qjulia::MeshFormat;
using qjulia::TriMesh;

namespace {

using fixtures::icosphere;

/// Colours from the position, spanning [0, 1] (0 and 1 exactly at the poles).
void paint(TriMesh& m) {
  m.colors.clear();
  for (const auto& p : m.positions) {
    m.colors.push_back({(p[0] + 1) / 2, (p[1] + 1) / 2, std::abs(p[2])});
  }
}

float srgb(float c) {
  return c <= 0.0031308f ? 12.92f * c : 1.055f * std::pow(c, 1.0f / 2.4f) - 0.055f;
}

using io_fixtures::TempDir;

const char* kParams = R"({"formula": "h^2", "method": "escape", "iterations": 12,
  "bailout": 4.0, "constants": {"c": [0.1, -0.2, 0, 0]}, "note": "a \"quoted\"\nline"})";

/// The decompressed entry `name` of the zip archive at `path` ("" when there is none).
std::string unzip_entry(const std::string& path, const char* name) {
  int err = 0;
  zip_t* z = zip_open(path.c_str(), ZIP_RDONLY, &err);
  if (!z) return "";
  std::string out;
  zip_stat_t st;
  if (zip_stat(z, name, 0, &st) == 0) {
    if (zip_file_t* f = zip_fopen(z, name, 0)) {
      out.resize(st.size);
      if (zip_fread(f, out.data(), st.size) != zip_int64_t(st.size)) out.clear();
      zip_fclose(f);
    }
  }
  zip_discard(z);
  return out;
}

std::string write_text(const std::string& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

/// Triangles as sets of positions (STL has no indices; its vertex order is its own).
std::multiset<std::array<float, 9>> position_triangles(const TriMesh& m) {
  std::multiset<std::array<float, 9>> out;
  for (const auto& t : m.triangles) {
    std::array<float, 9> k;
    for (int c = 0; c < 3; ++c)
      for (int i = 0; i < 3; ++i) k[3 * c + i] = m.positions[t[c]][i];
    out.insert(k);
  }
  return out;
}

void expect_unit_normals(const TriMesh& m) {
  ASSERT_EQ(m.normals.size(), m.positions.size());
  for (const auto& n : m.normals) {
    EXPECT_NEAR(std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]), 1.0, 1e-6);
  }
}

void expect_round_trip(const std::string& ext, bool colored) {
  TempDir dir;
  TriMesh mesh = icosphere(3);
  if (colored) paint(mesh);
  const std::string path = dir.file("sphere" + ext);
  qjulia::write_mesh(path, mesh, {kParams, "mm", {}});
  const TriMesh back = qjulia::read_mesh(path);
  SCOPED_TRACE(ext);
  if (ext == ".stl") {
    // Welded by position: the same vertices and the same triangles, in STL's own order.
    EXPECT_EQ(back.positions.size(), mesh.positions.size());
    EXPECT_EQ(position_triangles(back), position_triangles(mesh));
    return;
  }
  ASSERT_EQ(back.positions.size(), mesh.positions.size());
  if (ext == ".3mf") {
    // lib3mf 1.8 writes 6 decimals (1e-6 model units, a nanometre in mm).
    for (std::size_t v = 0; v < mesh.positions.size(); ++v)
      for (int i = 0; i < 3; ++i) EXPECT_NEAR(back.positions[v][i], mesh.positions[v][i], 1.5e-6);
  } else {
    EXPECT_EQ(back.positions, mesh.positions);  // bit-exact: binary, or shortest round-trip text
  }
  EXPECT_EQ(back.triangles, mesh.triangles);
  if (ext != ".3mf") {
    expect_unit_normals(back);
    // The writer's normals are area-weighted vertex normals: on a unit sphere close to p.
    for (std::size_t v = 0; v < mesh.positions.size(); ++v) {
      const auto& n = back.normals[v];
      const auto& p = mesh.positions[v];
      EXPECT_GT(n[0] * p[0] + n[1] * p[1] + n[2] * p[2], 0.99f);
    }
  }
  if (colored && ext != ".3mf") {
    ASSERT_EQ(back.colors.size(), mesh.colors.size());
    for (std::size_t v = 0; v < mesh.colors.size(); ++v)
      for (int i = 0; i < 3; ++i) {
        // 8-bit formats store sRGB: one step of 1/255 in the encoded value.
        EXPECT_NEAR(srgb(back.colors[v][i]), srgb(mesh.colors[v][i]), 1.0f / 255 + 1e-5f);
      }
  } else {
    EXPECT_TRUE(back.colors.empty());
  }
  EXPECT_EQ(dir.names().size(), ext == ".gltf" ? 2u : 1u);  // no temporary file left behind
}

using io_fixtures::kExtensions;

}  // namespace

TEST(Export, FormatIsChosenByExtensionIgnoringCase) {
  EXPECT_EQ(qjulia::format_from_path("a.glb"), MeshFormat::kGlb);
  EXPECT_EQ(qjulia::format_from_path("dir.x/a.GLTF"), MeshFormat::kGltf);
  EXPECT_EQ(qjulia::format_from_path("a.Obj"), MeshFormat::kObj);
  EXPECT_EQ(qjulia::format_from_path("a.PLY"), MeshFormat::kPly);
  EXPECT_EQ(qjulia::format_from_path("/x/a.stl"), MeshFormat::kStl);
  EXPECT_EQ(qjulia::format_from_path("a.3MF"), MeshFormat::k3mf);
  for (const auto f : {MeshFormat::kGlb, MeshFormat::kGltf, MeshFormat::kObj, MeshFormat::kPly,
                       MeshFormat::kStl, MeshFormat::k3mf}) {
    EXPECT_EQ(qjulia::format_from_path(std::string("m") + qjulia::extension_of(f)), f);
  }
}

TEST(Export, UnknownExtensionThrowsNamingItAndTheAcceptedOnes) {
  try {
    qjulia::format_from_path("mesh.xyz");
    FAIL() << "no exception";
  } catch (const InvalidInput& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("unknown output format '.xyz' (use .glb, .gltf, .obj, .ply, .stl or .3mf)"),
              std::string::npos)
        << msg;
  }
  EXPECT_THROW(qjulia::format_from_path("dir.glb/mesh"), InvalidInput);
  // Without an extension, the message says so in a sentence (it read "unknown output format no
  // extension").
  try {
    qjulia::format_from_path("/dev/full");
    FAIL() << "no exception";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(std::string(e.what()),
              "/dev/full: the output format follows the file's extension, and it has none (use "
              ".glb, .gltf, .obj, .ply, .stl or .3mf)");
  }
  TempDir dir;
  EXPECT_THROW(qjulia::write_mesh(dir.file("m.xyz"), icosphere(0)), InvalidInput);
  EXPECT_EQ(dir.names().size(), 0u);
}

TEST(Export, EveryFormatReadsBackWhatWasWritten) {
  for (const auto& ext : kExtensions) expect_round_trip(ext, false);
}

TEST(Export, EveryFormatWithColoursReadsBackWhatWasWritten) {
  for (const auto& ext : kExtensions) expect_round_trip(ext, true);
}

TEST(Export, EveryFormatButStlRecordsTheParameters) {
  const auto expected = nlohmann::json::parse(kParams);
  for (const auto& ext : kExtensions) {
    TempDir dir;
    const std::string path = dir.file("m" + ext);
    qjulia::write_mesh(path, icosphere(1), {kParams, "mm", {}});
    const std::string params = qjulia::read_mesh_params(path);
    if (ext == ".stl") {
      EXPECT_EQ(params, "");
    } else {
      EXPECT_EQ(nlohmann::json::parse(params), expected) << ext << ": " << params;
    }
  }
}

TEST(Export, EveryFormatWritesTheSameBytesForTheSameMesh) {
  // What is written depends only on the mesh, the parameters and the unit: 3MF's UUIDs, which
  // lib3mf would draw at random, are made from the content.
  TriMesh mesh = icosphere(2);
  paint(mesh);
  for (const auto& ext : kExtensions) {
    SCOPED_TRACE(ext);
    TempDir first, second;
    qjulia::write_mesh(first.file("m" + ext), mesh, {kParams, "mm", {}});
    qjulia::write_mesh(second.file("m" + ext), mesh, {kParams, "mm", {}});
    for (const std::string& name : {"m" + ext, std::string("m.bin")}) {
      if (name == "m.bin" && ext != ".gltf") continue;
      const std::string a = io_fixtures::read_bytes(first.file(name));
      EXPECT_GT(a.size(), 100u) << name;
      EXPECT_TRUE(a == io_fixtures::read_bytes(second.file(name))) << name << " differs";
    }
  }
}

TEST(Export, A3mfNamesItsObjectsByItsContent) {
  // The same content, the same UUIDs; another mesh or other parameters, other UUIDs.
  auto uuids = [](const TriMesh& mesh, const std::string& params) {
    TempDir dir;
    qjulia::write_mesh(dir.file("m.3mf"), mesh, {params, "mm", {}});
    const std::string model = unzip_entry(dir.file("m.3mf"), "3D/3dmodel.model");
    std::set<std::string> found;
    for (std::size_t at = model.find("UUID=\""); at != std::string::npos;
         at = model.find("UUID=\"", at + 1))
      found.insert(model.substr(at + 6, 36));
    return found;
  };
  const std::set<std::string> a = uuids(icosphere(2), kParams);
  ASSERT_EQ(a.size(), 3u) << "the object, the build and the build item";
  for (const std::string& u : a) {
    EXPECT_EQ(u[8], '-');
    EXPECT_EQ(u[14], '8') << u << ": version 8";
    EXPECT_NE(std::string("89ab").find(u[19]), std::string::npos) << u << ": variant 10";
  }
  EXPECT_EQ(uuids(icosphere(2), kParams), a);
  EXPECT_NE(uuids(icosphere(1), kParams), a);
  EXPECT_NE(uuids(icosphere(2), "{}"), a);
}

TEST(Export, GltfAssetExtrasIsTheParameterObjectAndGeneratorNamesQjulia) {
  TempDir dir;
  const std::string path = dir.file("m.gltf");
  qjulia::write_mesh(path, icosphere(1), {kParams, "", {}});
  std::ifstream in(path);
  const auto doc = nlohmann::json::parse(in);
  EXPECT_TRUE(doc["asset"]["extras"].is_object());
  EXPECT_EQ(doc["asset"]["extras"], nlohmann::json::parse(kParams));
  EXPECT_EQ(doc["asset"]["generator"].get<std::string>().rfind("qjulia ", 0), 0u);
  EXPECT_EQ(doc["buffers"][0]["uri"], "m.bin");
  EXPECT_EQ(qjulia::output_files(path), (std::vector<std::string>{path, dir.file("m.bin")}));
  EXPECT_EQ(qjulia::output_files("a.GLB"), std::vector<std::string>{"a.GLB"});
  EXPECT_TRUE(fs::exists(dir.file("m.bin")));
  EXPECT_EQ(doc["meshes"].size(), 1u);
  EXPECT_EQ(doc["meshes"][0]["primitives"].size(), 1u);
  EXPECT_FALSE(doc["nodes"][0].contains("matrix"));
  EXPECT_EQ(doc["materials"][0]["pbrMetallicRoughness"]["metallicFactor"], 0.0);
}

TEST(Export, StlHeaderNamesQjuliaAndTheUnitAndWeldsBackToTheIndexedMesh) {
  TempDir dir;
  const std::string path = dir.file("m.stl");
  const TriMesh mesh = icosphere(2);
  qjulia::write_mesh(path, mesh, {"", "mm", {}});
  std::ifstream in(path, std::ios::binary);
  std::string header(80, '\0');
  in.read(header.data(), 80);
  EXPECT_EQ(header.rfind("qjulia", 0), 0u) << header;
  EXPECT_NE(header.find("mm"), std::string::npos) << header;
  EXPECT_EQ(fs::file_size(path), 84 + 50 * mesh.triangles.size());
  EXPECT_EQ(qjulia::read_mesh(path).positions.size(), mesh.positions.size());
}

TEST(Export, MissingOrBrokenNormalsAreReplacedByUnitOnes) {
  // A degenerate triangle (zero area), an isolated vertex, a zero and a NaN given normal.
  TriMesh m = icosphere(1);
  const uint32_t a = uint32_t(m.positions.size());
  m.positions.push_back({5, 5, 5});
  m.positions.push_back({5, 5, 5});
  m.positions.push_back({6, 5, 5});  // collinear with the first two: zero area
  m.positions.push_back({9, 9, 9});  // referenced by no triangle
  m.triangles.push_back({a, a + 1, a + 2});
  for (const auto& ext : {".glb", ".ply", ".obj"}) {
    TempDir dir;
    qjulia::write_mesh(dir.file(std::string("m") + ext), m);
    expect_unit_normals(qjulia::read_mesh(dir.file(std::string("m") + ext)));
  }
  TriMesh given = m;
  given.normals.assign(m.positions.size(), {0, 0, 2});
  given.normals[0] = {0, 0, 0};
  given.normals[1] = {NAN, 0, 0};
  TempDir dir;
  qjulia::write_mesh(dir.file("m.glb"), given);
  const TriMesh back = qjulia::read_mesh(dir.file("m.glb"));
  expect_unit_normals(back);
  EXPECT_EQ(back.normals[2], (std::array<float, 3>{0, 0, 1}));  // given (0,0,2), normalized
}

// A PLY of a mesh without normals makes them while its face section goes out (from its first
// aligned byte on, by threads of their own, when two threads may run): the same bytes as the PLY
// of the mesh given those normals, on any thread count, with records of 24 and 27 bytes and
// headers of several lengths (so the face section starts at several offsets in a block).
TEST(Export, APlyMakesMissingNormalsWhileItsFacesGoOutWithTheSameBytes) {
  TriMesh bare = icosphere(8);  // 1,310,720 faces: a face section of 17 MB
  bare.normals.clear();
  ASSERT_GT(bare.triangles.size() * qjulia::detail::kPlyFaceRecord,
            qjulia::detail::kPlyAheadLeast + 4096);
  TriMesh coloured = bare;
  coloured.colors.resize(bare.positions.size());
  for (std::size_t v = 0; v < coloured.colors.size(); ++v)
    coloured.colors[v] = {float(v % 7) / 7, float(v % 5) / 5, 0.5f};
  TempDir dir;
  for (const TriMesh* m : {&bare, &coloured})
    for (const char* params : {"", R"({"preset": "a"})", R"({"a": [1, 2, 3], "bb": "cc"})"}) {
      SCOPED_TRACE(std::string(params) + (m->colors.empty() ? "" : ", coloured"));
      qjulia::ExportOptions opts;
      opts.params_json = params;
      TriMesh given = *m;
      given.normals = qjulia::area_weighted_normals(*m);
      qjulia::write_mesh(dir.file("given.ply"), given, opts);
      const std::string expected = io_fixtures::read_bytes(dir.file("given.ply"));
      for (int threads : {1, 2, 3}) {
        tbb::task_arena arena(threads);
        arena.execute([&] { qjulia::write_mesh(dir.file("made.ply"), *m, opts); });
        EXPECT_TRUE(io_fixtures::read_bytes(dir.file("made.ply")) == expected)
            << threads << " threads";
      }
    }
}

TEST(Export, AFailedWriteLeavesNoFile) {
  TempDir dir;
  for (const auto& ext : kExtensions) {
    EXPECT_THROW(qjulia::write_mesh(dir.file("no/such/dir/m" + ext), icosphere(0)), InvalidInput);
  }
  TriMesh bad = icosphere(1);
  bad.triangles[7][1] = uint32_t(bad.positions.size());
  TriMesh empty;
  TriMesh wrong_colors = icosphere(1);
  wrong_colors.colors.resize(3);
  for (const auto& ext : kExtensions) {
    try {
      qjulia::write_mesh(dir.file("m" + ext), bad);
      ADD_FAILURE() << "no exception for " << ext;
    } catch (const InvalidInput& e) {
      EXPECT_NE(std::string(e.what()).find("triangle 7"), std::string::npos) << e.what();
    }
    EXPECT_THROW(qjulia::write_mesh(dir.file("m" + ext), empty), InvalidInput);
    EXPECT_THROW(qjulia::write_mesh(dir.file("m" + ext), wrong_colors), InvalidInput);
    EXPECT_THROW(qjulia::write_mesh(dir.file("m" + ext), icosphere(0), {"{not json", "", {}}),
                 InvalidInput);
  }
  EXPECT_EQ(dir.names().size(), 0u);
}

TEST(Export, AnExistingFileIsReplacedWhole) {
  TempDir dir;
  const std::string path = dir.file("m.ply");
  write_text(path, std::string(10'000'000, 'x'));
  qjulia::write_mesh(path, icosphere(1));
  EXPECT_LT(fs::file_size(path), 10'000u);
  EXPECT_EQ(qjulia::read_mesh(path).triangles.size(), 80u);
  EXPECT_EQ(dir.names().size(), 1u);
}

TEST(Export, CancellingBeforeWritingLeavesNoFile) {
  TempDir dir;
  qjulia::ExportOptions opts;
  opts.progress = [](double) { return false; };
  EXPECT_THROW(qjulia::write_mesh(dir.file("m.glb"), icosphere(1), opts), qjulia::Cancelled);
  EXPECT_EQ(dir.names().size(), 0u);
}

TEST(Export, GarbageTruncatedOrMissingFilesThrowNamingTheFile) {
  for (const auto& ext : kExtensions) {
    SCOPED_TRACE(ext);
    TempDir dir;
    auto expect_invalid = [&](const std::string& path) {
      try {
        qjulia::read_mesh(path);
        ADD_FAILURE() << "no exception for " << path;
      } catch (const InvalidInput& e) {
        const std::string msg = e.what();
        EXPECT_EQ(msg.rfind(path + ": ", 0), 0u) << msg;
        EXPECT_GT(msg.size(), path.size() + 8) << msg;
      }
    };
    expect_invalid(dir.file("missing" + ext));
    expect_invalid(write_text(dir.file("empty" + ext), ""));
    expect_invalid(write_text(dir.file("garbage" + ext), std::string(1000, '\x17') + "garbage"));
    const std::string good = dir.file("good" + ext);
    qjulia::write_mesh(good, icosphere(2));
    std::ifstream in(good, std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    for (const double keep : {0.5, 0.9}) {
      if (ext == ".obj" || ext == ".gltf") continue;  // text: a prefix may be a valid file
      expect_invalid(
          write_text(dir.file("cut" + ext), bytes.substr(0, std::size_t(bytes.size() * keep))));
    }
  }
  {
    TempDir dir;  // a .gltf whose .bin is missing or short
    qjulia::write_mesh(dir.file("m.gltf"), icosphere(2));
    const auto bin = dir.file("m.bin");
    fs::resize_file(bin, fs::file_size(bin) / 2);
    EXPECT_THROW(qjulia::read_mesh(dir.file("m.gltf")), InvalidInput);
    fs::remove(bin);
    EXPECT_THROW(qjulia::read_mesh(dir.file("m.gltf")), InvalidInput);
  }
  EXPECT_THROW(qjulia::read_mesh("mesh.xyz"), InvalidInput);
}

TEST(Export, ReadersAcceptOtherProgramsVariants) {
  TempDir dir;
  // OBJ: quads, negative indices, v/vt/vn, comments, CRLF.
  const TriMesh quad = qjulia::read_mesh(
      write_text(dir.file("q.obj"),
                 "# cube face\r\nv 0 0 0\r\nv 1 0 0\r\nv 1 1 0\r\nv 0 1 0\r\nvt 0 0\r\nvn 0 0 1\r\n"
                 "f 1/1/1 2/1/1 3/1/1 4/1/1\r\nf -4 -2 -1\r\n"));
  EXPECT_EQ(quad.positions.size(), 4u);
  ASSERT_EQ(quad.triangles.size(), 3u);
  EXPECT_EQ(quad.triangles[1], (std::array<uint32_t, 3>{0, 2, 3}));
  EXPECT_EQ(quad.triangles[2], (std::array<uint32_t, 3>{0, 2, 3}));
  // ASCII PLY with an extra element and a quad.
  const TriMesh ply = qjulia::read_mesh(write_text(
      dir.file("a.ply"),
      "ply\nformat ascii 1.0\ncomment hi\nelement vertex 4\nproperty double x\nproperty double y\n"
      "property double z\nelement face 1\nproperty list uchar uint vertex_index\n"
      "element edge 1\nproperty int vertex1\nproperty int vertex2\nend_header\n"
      "0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n0 1\n"));
  EXPECT_EQ(ply.positions.size(), 4u);
  EXPECT_EQ(ply.triangles.size(), 2u);
  // ASCII STL: two triangles sharing an edge weld to 4 vertices.
  const TriMesh stl = qjulia::read_mesh(write_text(
      dir.file("a.stl"),
      "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 1 1 0\n"
      "endloop\nendfacet\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 1 0\n"
      "vertex -0 1 0\nendloop\nendfacet\nendsolid t\n"));
  EXPECT_EQ(stl.positions.size(), 4u);
  EXPECT_EQ(stl.triangles.size(), 2u);
}

TEST(Export, CorruptedFilesEitherReadOrThrowInvalidInput) {
  // A poor man's fuzzer: random byte flips and cuts of valid files must never crash a reader
  // or throw anything but InvalidInput.
  std::mt19937 rng(12345);
  for (const auto& ext : kExtensions) {
    SCOPED_TRACE(ext);
    TempDir dir;
    TriMesh mesh = icosphere(1);
    paint(mesh);
    const std::string good = dir.file("good" + ext);
    qjulia::write_mesh(good, mesh, {kParams, "mm", {}});
    std::ifstream in(good, std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const std::string path = dir.file("bad" + ext);
    for (int round = 0; round < 150; ++round) {
      std::string b = bytes;
      const int flips = 1 + int(rng() % 8);
      for (int k = 0; k < flips; ++k) b[rng() % b.size()] = char(rng());
      if (round % 3 == 0) b.resize(rng() % b.size());
      write_text(path, b);
      try {
        const TriMesh m = qjulia::read_mesh(path);
        for (const auto& t : m.triangles)
          for (uint32_t i : t) ASSERT_LT(i, m.positions.size());
        qjulia::read_mesh_params(path);
      } catch (const InvalidInput&) {
      }
    }
  }
}
