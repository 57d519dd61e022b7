// The door of the library: validate_mesh and the readers' policy, counts checked before
// anything is allocated, memory limits, glTF buffer URIs, 3MF decompression, reading from
// memory, cancellation of the writers, and the fuzzers' regression inputs.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <tbb/task_arena.h>
#include <zip.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <iostream>
#include <nlohmann/json.hpp>

#include "base/placement.h"
#include "base/weld.h"
#include "io_fixtures.h"
#include "qjulia/base/error.h"
#include "qjulia/base/validate.h"
#include "qjulia/io/mesh_io.h"
#include "qjulia/mesh/clean.h"
#include "qjulia/mesh/compare.h"
#include "qjulia/mesh/decimate.h"
#include "qjulia/mesh/print.h"
#include "qjulia/render/render.h"
#include "test_meshes.h"

namespace {

using io_fixtures::read_bytes;
using io_fixtures::TempDir;
using io_fixtures::write_bytes;
using qjulia::InvalidInput;
using qjulia::MeshFormat;
using qjulia::TriMesh;
namespace fs = std::filesystem;

using io_fixtures::kExtensions;

/// The message of the InvalidInput `f` throws ("" and a test failure when it throws none).
template <class F>
std::string refusal(F&& f) {
  try {
    f();
  } catch (const InvalidInput& e) {
    return e.what();
  }
  ADD_FAILURE() << "no InvalidInput";
  return "";
}

bool has(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

TriMesh tetrahedron() {
  TriMesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  m.triangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  return m;
}

const char* kPlyHead =
    "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
    "property float z\nelement face 3\nproperty list uchar int vertex_indices\nend_header\n";

// ------------------------------------------------------------------------ validate_mesh

TEST(Validate, AcceptsDegenerateFacesUnreferencedVerticesAndUnusableNormals) {
  TriMesh m = tetrahedron();
  m.positions.push_back({5, 5, 5});      // unreferenced
  m.triangles.push_back({0, 0, 1});      // repeated index
  m.normals.assign(5, {NAN, 0, 0});      // replaced by the writers and the renderer
  m.colors.assign(5, {2.0f, -1.0f, 0});  // clamped by them
  EXPECT_NO_THROW(qjulia::validate_mesh(m, "m", {true}));
  EXPECT_NO_THROW(qjulia::validate_mesh(TriMesh{}, "empty"));
}

TEST(Validate, NamesTheSourceAndTheFirstBadTriangleOrVertex) {
  TriMesh m = tetrahedron();
  m.triangles[2][1] = 9;
  m.triangles[3][0] = 12;
  EXPECT_EQ(refusal([&] { qjulia::validate_mesh(m, "src"); }),
            "src: triangle 2 has vertex index 9 but the mesh has 4 vertices");
  m = tetrahedron();
  m.positions[2][1] = INFINITY;
  m.positions[3][0] = NAN;
  EXPECT_EQ(refusal([&] { qjulia::validate_mesh(m, "src"); }),
            "src: vertex 2 has a non-finite position");
  m = tetrahedron();
  m.normals.resize(3);
  EXPECT_TRUE(has(refusal([&] { qjulia::validate_mesh(m, "src"); }),
                  "src: the mesh has 3 normals for 4 vertices"));
  m = tetrahedron();
  m.colors.resize(5);
  EXPECT_TRUE(has(refusal([&] { qjulia::validate_mesh(m, "src"); }),
                  "src: the mesh has 5 colours for 4 vertices"));
  EXPECT_EQ(refusal([&] { qjulia::validate_mesh(TriMesh{}, "src", {true}); }),
            "src: the mesh has no triangles");
}

TEST(Validate, EveryFunctionThatTakesAMeshGivesTheSameVerdict) {
  TriMesh nan = fixtures::icosphere(1);
  nan.positions[2][0] = NAN;
  TriMesh bad_index = fixtures::icosphere(1);
  bad_index.triangles[1][2] = 1000;
  TempDir dir;
  const TriMesh good = fixtures::icosphere(1);
  qjulia::DecimateOptions dec;
  dec.faces = 20;
  qjulia::ThickenOptions thick;
  thick.min_thickness = 0.1;
  for (const TriMesh* m : {&nan, &bad_index}) {
    const std::string expected = m == &nan ? "vertex 2 has a non-finite position"
                                           : "triangle 1 has vertex index 1000 but the mesh has";
    const std::vector<std::pair<std::string, std::function<void()>>> calls = {
        {"clean", [&] { qjulia::clean(*m); }},
        {"decimate", [&] { qjulia::decimate(*m, dec); }},
        {"compare", [&] { qjulia::compare(*m, good); }},
        {"compare", [&] { qjulia::compare(good, *m); }},
        {"render", [&] { qjulia::render(*m); }},
        {"printability", [&] { qjulia::printability(*m); }},
        {"thicken", [&] { qjulia::thicken(*m, thick); }},
        {dir.file("m.ply"), [&] { qjulia::write_mesh(dir.file("m.ply"), *m); }},
        {"measure", [&] { qjulia::measure(*m); }},
        {"face_components", [&] { qjulia::face_components(*m); }},
        {"normals", [&] { qjulia::area_weighted_normals(*m); }},
        {"normals",
         [&] {
           TriMesh copy = *m;
           qjulia::compute_normals(copy);
         }},
        {"print",
         [&] {
           TriMesh copy = *m;
           qjulia::scale_to_longest_side(copy, 10);
         }},
        {"self-intersections", [&] { qjulia::count_self_intersections(*m); }}};
    for (const auto& [name, call] : calls) {
      const std::string msg = refusal(call);
      EXPECT_EQ(msg.rfind(name, 0), 0u) << msg;
      EXPECT_TRUE(has(msg, expected)) << msg;
    }
  }
}

TEST(Validate, ComputeNormalsReplacesNormalsOfAnyCountAndKeepsThemOnAFailure) {
  TriMesh m = fixtures::icosphere(1);
  m.normals.assign(3, {1, 0, 0});  // stale: fewer than the vertices
  qjulia::compute_normals(m);
  EXPECT_EQ(m.normals, qjulia::area_weighted_normals(fixtures::icosphere(1)));
  m.positions[0][0] = NAN;
  m.normals.assign(3, {1, 0, 0});
  EXPECT_THROW(qjulia::compute_normals(m), InvalidInput);
  EXPECT_EQ(m.normals.size(), 3u);
}

TEST(Validate, FaceComponentsNumbersThemInTheOrderOfTheirFirstFace) {
  TriMesh two = tetrahedron();
  for (const auto& p : tetrahedron().positions) two.positions.push_back({p[0] + 5, p[1], p[2]});
  two.triangles = {{4, 6, 5}, {0, 2, 1}, {4, 5, 7}, {0, 1, 3},
                   {4, 7, 6}, {0, 3, 2}, {5, 6, 7}, {1, 2, 3}};
  EXPECT_EQ(qjulia::face_components(two), (std::vector<std::uint32_t>{0, 1, 0, 1, 0, 1, 0, 1}));
  EXPECT_TRUE(qjulia::face_components(TriMesh{}).empty());
}

// ------------------------------------------------------------------------ readers' policy

TEST(Readers, DropTrianglesWithARepeatedIndexKeepUnreferencedVerticesAndReportBoth) {
  TempDir dir;
  const std::string ply =
      write_bytes(dir.file("m.ply"), std::string(kPlyHead) +
                                         "0 0 0\n1 0 0\n"
                                         "0 1 0\n7 7 7\n3 0 1 1\n3 0 1 2\n3 2 2 2\n");
  qjulia::ReadReport report;
  qjulia::ReadOptions opts;
  opts.report = &report;
  const TriMesh m = qjulia::read_mesh(ply, opts);
  EXPECT_EQ(m.positions.size(), 4u);
  ASSERT_EQ(m.triangles.size(), 1u);
  EXPECT_EQ(m.triangles[0], (std::array<uint32_t, 3>{0, 1, 2}));
  EXPECT_EQ(report.dropped_faces, 2u);
  EXPECT_EQ(report.unreferenced_vertices, 1u);

  // OBJ, and STL whose welded corners coincide: the same policy.
  const std::string obj = write_bytes(dir.file("m.obj"),
                                      "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 3 3 3\n"
                                      "f 1 2 2\nf 1 2 3\n");
  EXPECT_EQ(qjulia::read_mesh(obj, opts).triangles.size(), 1u);
  EXPECT_EQ(report.dropped_faces, 1u);
  EXPECT_EQ(report.unreferenced_vertices, 1u);
  const std::string stl = write_bytes(
      dir.file("m.stl"),
      "solid s\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\n"
      "endloop\nendfacet\nfacet normal 0 0 0\nouter loop\nvertex 0 0 0\nvertex 0 0 0\n"
      "vertex 1 0 0\nendloop\nendfacet\nendsolid s\n");
  EXPECT_EQ(qjulia::read_mesh(stl, opts).triangles.size(), 1u);
  EXPECT_EQ(report.dropped_faces, 1u);

  const std::string none = write_bytes(dir.file("none.ply"), std::string(kPlyHead) +
                                                                 "0 0 0\n1 0 0\n0 1 0\n7 7 7\n"
                                                                 "3 0 1 1\n3 0 0 1\n3 2 2 2\n");
  EXPECT_EQ(refusal([&] { qjulia::read_mesh(none); }),
            none + ": every triangle has a repeated vertex index (no area)");
}

/// Writes the tetrahedron in `ext` with the position of vertex 0 (the first corner in STL)
/// made NaN in the file's bytes.
std::string nan_file(const TempDir& dir, const std::string& ext) {
  const std::string path = dir.file("nan" + ext);
  qjulia::write_mesh(path, tetrahedron());
  const float nan = NAN;
  auto patch = [&](const std::string& file, std::size_t offset) {
    std::string b = read_bytes(file);
    std::memcpy(&b[offset], &nan, 4);
    write_bytes(file, b);
  };
  if (ext == ".ply") {
    patch(path, read_bytes(path).find("end_header\n") + 11);
  } else if (ext == ".stl") {
    patch(path, 84 + 12);
  } else if (ext == ".glb") {
    uint32_t json = 0;
    std::memcpy(&json, read_bytes(path).data() + 12, 4);
    patch(path, 20 + json + 8 + 4 * 12);  // after the 4 triangles
  } else if (ext == ".gltf") {
    patch(dir.file("nan.bin"), 4 * 12);
  } else if (ext == ".obj") {
    std::string b = read_bytes(path);
    const auto v = b.find("\nv ") + 3;
    b.replace(v, b.find(' ', v) - v, "nan");
    write_bytes(path, b);
  }
  return path;
}

TEST(Readers, ANonFinitePositionGetsTheSameVerdictInEveryFormat) {
  TempDir dir;
  for (const std::string ext : {".glb", ".gltf", ".obj", ".ply", ".stl"}) {
    const std::string path = nan_file(dir, ext);
    const std::string msg = refusal([&] { qjulia::read_mesh(path); });
    EXPECT_EQ(msg, path + ": vertex 0 has a non-finite position") << ext;
  }
}

TEST(Readers, CountsAreCheckedAgainstTheFileSizeBeforeAnythingIsAllocated) {
  TempDir dir;
  // 4e9 vertices announced in a 200-byte file: refused at once, not allocated (a 1 MiB
  // limit would make any allocation of them TooLarge instead).
  qjulia::ReadOptions small;
  small.max_memory = std::size_t(1) << 20;
  for (const std::string format : {"ascii", "binary_little_endian", "binary_big_endian"}) {
    const std::string path =
        write_bytes(dir.file(format + ".ply"),
                    "ply\nformat " + format +
                        " 1.0\nelement vertex 4000000000\nproperty float x\nproperty float y\n"
                        "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                        "end_header\n" +
                        std::string(64, '0'));
    try {
      qjulia::read_mesh(path, small);
      ADD_FAILURE() << "read";
    } catch (const qjulia::TooLarge& e) {
      ADD_FAILURE() << "allocation was attempted: " << e.what();
    } catch (const InvalidInput& e) {
      EXPECT_TRUE(has(e.what(), "announces 4000000000 records")) << e.what();
    }
  }
  // A binary STL whose count does not match its size; a GLB accessor counting past its buffer.
  std::string stl(80, ' ');
  const uint32_t count = 100000000;
  stl.append(reinterpret_cast<const char*>(&count), 4);
  stl += std::string(50, '\0');
  const std::string stl_path = write_bytes(dir.file("count.stl"), stl);
  EXPECT_TRUE(has(refusal([&] { qjulia::read_mesh(stl_path, small); }), "100000000 triangles"));
  const std::string glb = dir.file("count.glb");
  qjulia::write_mesh(glb, tetrahedron());
  std::string b = read_bytes(glb);
  const std::string key = "\"count\":4";  // the positions' accessor
  ASSERT_NE(b.find(key), std::string::npos);
  b.replace(b.find(key), key.size(), "\"count\":9");
  write_bytes(glb, b);
  EXPECT_TRUE(has(refusal([&] { qjulia::read_mesh(glb, small); }), "reaches past the end"));
}

TEST(Readers, AMeshThatWouldNotFitTheMemoryLimitIsTooLarge) {
  TempDir dir;
  // 200000 vertices of three bytes each: a 600 kB file whose positions take 2.4 MB.
  const std::size_t n = 200000;
  std::string ply = "ply\nformat binary_little_endian 1.0\nelement vertex " + std::to_string(n) +
                    "\nproperty uchar x\nproperty uchar y\nproperty uchar z\nelement face 1\n"
                    "property list uchar int vertex_indices\nend_header\n";
  for (std::size_t v = 0; v < n; ++v) ply += std::string{char(v), char(v >> 8), char(v >> 16)};
  ply += '\3';
  for (int32_t i : {0, 1, 2}) ply.append(reinterpret_cast<const char*>(&i), 4);
  const std::string path = write_bytes(dir.file("big.ply"), ply);
  qjulia::ReadOptions opts;
  opts.max_memory = std::size_t(2) << 20;
  try {
    qjulia::read_mesh(path, opts);
    ADD_FAILURE() << "read";
  } catch (const qjulia::TooLarge& e) {
    const std::string msg = e.what();
    EXPECT_EQ(msg.rfind(path + ": reading it needs at least ", 0), 0u) << msg;
    EXPECT_TRUE(has(msg, "(vertices)")) << msg;
    EXPECT_TRUE(has(msg, "2.00 MiB")) << msg;
  }
  opts.max_memory = std::size_t(8) << 20;
  EXPECT_EQ(qjulia::read_mesh(path, opts).positions.size(), n);
}

TEST(Readers, OnlyRegularFilesAreReadAndAFifoDoesNotBlock) {
  TempDir dir;
  ASSERT_EQ(::mkfifo(dir.file("fifo.ply").c_str(), 0644), 0);
  EXPECT_EQ(refusal([&] { qjulia::read_mesh(dir.file("fifo.ply")); }),
            dir.file("fifo.ply") + ": cannot read the file (not a regular file)");
  fs::create_symlink("/dev/zero", dir.file("zero.stl"));
  EXPECT_TRUE(has(refusal([&] { qjulia::read_mesh(dir.file("zero.stl")); }), "not a regular file"));
  fs::create_directory(dir.file("dir.obj"));
  EXPECT_TRUE(has(refusal([&] { qjulia::read_mesh(dir.file("dir.obj")); }), "not a regular file"));
  // The format comes from the extension: without one, or with an unknown one, the message says
  // which (it read "unknown mesh format (no extension) (readable: ...)").
  EXPECT_EQ(refusal([&] { qjulia::read_mesh("/dev/null"); }),
            "/dev/null: the mesh format follows the file's extension, and it has none "
            "(readable: .glb, .gltf, .obj, .ply, .stl, .3mf)");
  EXPECT_EQ(refusal([&] { qjulia::read_mesh(dir.file("m.xyz")); }),
            dir.file("m.xyz") +
                ": unknown mesh format '.xyz' (readable: .glb, .gltf, .obj, .ply, "
                ".stl, .3mf)");
}

TEST(Readers, FromMemoryTheyGiveWhatTheyGiveFromAFile) {
  TempDir dir;
  TriMesh mesh = fixtures::icosphere(2);
  for (const auto& ext : kExtensions) {
    const std::string path = dir.file("m" + ext);
    qjulia::write_mesh(path, mesh);
    if (ext == ".gltf") continue;  // its buffer is a file: from memory only data: URIs
    const TriMesh a = qjulia::read_mesh(path);
    qjulia::ReadOptions opts;
    opts.name = "bytes" + ext;
    const TriMesh b =
        qjulia::read_mesh_from_memory(read_bytes(path), qjulia::format_from_path(path), opts);
    EXPECT_EQ(a.positions, b.positions) << ext;
    EXPECT_EQ(a.triangles, b.triangles) << ext;
    EXPECT_EQ(a.normals, b.normals) << ext;
    EXPECT_EQ(refusal([&] {
                qjulia::read_mesh_from_memory("garbage", qjulia::format_from_path(path), opts);
              }).rfind("bytes" + ext + ": ", 0),
              0u);
  }
  const std::string gltf = read_bytes(dir.file("m.gltf"));
  const std::string msg = refusal([&] { qjulia::read_mesh_from_memory(gltf, MeshFormat::kGltf); });
  EXPECT_TRUE(has(msg,
                  "<memory>: refused: URI 'm.bin' names a file, but the glTF was read "
                  "from memory"))
      << msg;
}

// ------------------------------------------------------------------------ glTF buffer URIs

/// A .gltf in `dir` whose buffer URI is `uri` (the buffer itself written as m.bin beside it).
std::string gltf_with_uri(const TempDir& dir, const std::string& uri) {
  const std::string path = dir.file("m.gltf");
  qjulia::write_mesh(path, tetrahedron());
  auto doc = nlohmann::json::parse(read_bytes(path));
  doc["buffers"][0]["uri"] = uri;
  write_bytes(path, doc.dump());
  return path;
}

TEST(Gltf, BufferUrisMayOnlyNameRegularFilesInsideTheFolder) {
  TempDir outside;
  TempDir dir;
  const std::string bin_bytes =
      read_bytes(fs::path(gltf_with_uri(dir, "m.bin")).replace_extension(".bin"));
  write_bytes(outside.file("m.bin"), bin_bytes);
  fs::create_directory(dir.file("sub"));
  write_bytes(dir.file("sub/b.bin"), bin_bytes);
  fs::create_symlink(outside.file("m.bin"), dir.file("out.bin"));
  fs::create_symlink(dir.file("m.bin"), dir.file("in.bin"));
  ASSERT_EQ(::mkfifo(dir.file("fifo.bin").c_str(), 0644), 0);
  fs::create_symlink("/dev/zero", dir.file("zero.bin"));

  // Read: the file beside it, in a subfolder, through a link that stays inside, percent-encoded.
  for (const std::string uri : {"m.bin", "sub/b.bin", "in.bin", "%6D.bin"})
    EXPECT_EQ(qjulia::read_mesh(gltf_with_uri(dir, uri)).triangles.size(), 4u) << uri;
  // Refused, each naming the URI and why.
  const std::vector<std::pair<std::string, std::string>> refused = {
      {"../" + outside.path().filename().string() + "/m.bin", "leaves the folder"},
      {"%2E%2E/" + outside.path().filename().string() + "/m.bin", "leaves the folder"},
      {outside.file("m.bin"), "is an absolute path"},
      {"/dev/zero", "is an absolute path"},
      {"out.bin", "is a link leading out of the folder"},
      {"fifo.bin", "is not a regular file"},
      {"zero.bin", "is a link leading out of the folder"},
      {"sub", "is not a regular file"},
      {"file:///etc/passwd", "is a URI with a scheme"},
      {"missing.bin", "does not exist"}};
  for (const auto& [uri, why] : refused) {
    const std::string path = gltf_with_uri(dir, uri);
    const std::string msg = refusal([&] { qjulia::read_mesh(path); });
    EXPECT_EQ(msg.rfind(path + ": refused: URI '", 0), 0u) << msg;
    EXPECT_TRUE(has(msg, why)) << uri << ": " << msg;
  }
}

// The one weld of the readers and measures: numbers in the order of first occurrence, -0 and +0
// one position, the first position of each number kept.
TEST(Weld, PositionsAreNumberedInTheOrderTheyFirstAppear) {
  const std::vector<std::array<float, 3>> p = {{1, 2, 3}, {0, -0.0f, 1}, {1, 2, 3},
                                               {4, 5, 6}, {0, 0, 1},     {4, 5, 6.0001f}};
  std::vector<std::uint32_t> index(p.size());
  ASSERT_EQ(qjulia::detail::number_positions(p.data(), p.size(), index.data()), 4u);
  EXPECT_EQ(index, (std::vector<std::uint32_t>{0, 1, 0, 2, 1, 3}));
  std::vector<std::array<float, 3>> welded(4);
  qjulia::detail::first_positions(p.data(), p.size(), index.data(), welded.data());
  EXPECT_EQ(welded[0], p[0]);
  EXPECT_EQ(welded[2], p[3]);
  EXPECT_EQ(welded[3], p[5]);
  EXPECT_FALSE(std::signbit(welded[1][1]));  // -0 -> +0, as the positions were keyed
}

// The placements of glTF nodes and 3MF items: composition, a mirror's winding and normals.
TEST(Placement, ComposedPlacementsMoveAndAMirrorReversesTheWinding) {
  namespace d = qjulia::detail;
  const d::Placement shift = {1, 0, 0, 5, 0, 1, 0, 0, 0, 0, 1, 0};
  const d::Placement quarter = {0, -1, 0, 0, 1, 0, 0, 0, 0, 0, 1, 0};  // 90 degrees about z
  std::array<float, 3> p[1] = {{1, 0, 0}};
  d::place_positions(d::compose(shift, quarter), p, 1);  // turned first, then moved
  EXPECT_EQ(p[0], (std::array<float, 3>{5, 1, 0}));
  EXPECT_EQ(d::compose(d::kUnmoved, quarter), quarter);
  EXPECT_DOUBLE_EQ(d::determinant(quarter), 1);
  std::array<std::uint32_t, 3> t[1] = {{0, 1, 2}};
  d::keep_outward(quarter, t, 1);
  EXPECT_EQ(t[0], (std::array<std::uint32_t, 3>{0, 1, 2}));
  const d::Placement mirror_squash = {-1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 0.5, 0};
  EXPECT_DOUBLE_EQ(d::determinant(mirror_squash), -0.5);
  d::keep_outward(mirror_squash, t, 1);
  EXPECT_EQ(t[0], (std::array<std::uint32_t, 3>{0, 2, 1}));
  // The normal of the plane x + z = 0 after x -> -x, z -> z / 2: the plane -x + 2z = 0, whose
  // normal (-1, 0, 2) / sqrt(5) keeps the side it faced.
  std::array<float, 3> n[1] = {{float(std::sqrt(0.5)), 0, float(std::sqrt(0.5))}};
  d::place_normals(mirror_squash, n, 1);
  EXPECT_NEAR(n[0][0], -1 / std::sqrt(5.0), 1e-6);
  EXPECT_NEAR(n[0][1], 0, 1e-6);
  EXPECT_NEAR(n[0][2], 2 / std::sqrt(5.0), 1e-6);
}

// A glTF's nodes place its meshes (Blender writes each object's transform in its node): the
// scene's hierarchy is applied, a mesh used by two nodes is read twice, a mirroring node keeps
// the faces and normals outward, and a file without nodes is read as it is.
TEST(Gltf, NodesPlaceTheirMeshesAndAMirrorKeepsTheFacesOutward) {
  TempDir dir;
  qjulia::write_mesh(dir.file("t.gltf"), tetrahedron());
  const nlohmann::json doc = nlohmann::json::parse(read_bytes(dir.file("t.gltf")));
  auto with = [&](const nlohmann::json& nodes, const nlohmann::json& scene_nodes) {
    nlohmann::json d = doc;
    d.erase("scenes");
    d.erase("scene");
    d.erase("nodes");
    if (!nodes.is_null()) d["nodes"] = nodes;
    if (!scene_nodes.is_null()) {
      d["scenes"] = nlohmann::json::array({{{"nodes", scene_nodes}}});
      d["scene"] = 0;
    }
    write_bytes(dir.file("n.gltf"), d.dump());  // its buffer is t.bin, beside it
    return qjulia::read_mesh(dir.file("n.gltf"));
  };
  const double tetra = 1.0 / 6;
  // Node 0 moves by (5, 0, 0) and scales by 2; its child, node 1, turns the mesh by 90 degrees
  // about z; node 2 holds the mesh as it is.
  const double h = std::sqrt(0.5);
  const nlohmann::json nodes = {
      {{"translation", {5, 0, 0}}, {"scale", {2, 2, 2}}, {"children", {1}}},
      {{"rotation", {0, 0, h, h}}, {"mesh", 0}},
      {{"mesh", 0}}};
  const TriMesh placed = with(nodes, {0, 2});
  ASSERT_EQ(placed.positions.size(), 8u);
  ASSERT_EQ(placed.triangles.size(), 8u);
  const std::array<std::array<float, 3>, 4> expected = {
      {{5, 0, 0}, {5, 2, 0}, {3, 0, 0}, {5, 0, 2}}};  // (x, y, z) -> (5 - 2y, 2x, 2z)
  for (int v = 0; v < 4; ++v)
    for (int a = 0; a < 3; ++a)
      EXPECT_NEAR(placed.positions[v][a], expected[v][a], 1e-6) << v << " " << a;
  EXPECT_EQ(placed.positions[4], tetrahedron().positions[0]);
  EXPECT_NEAR(fixtures::volume(placed), 8 * tetra + tetra, 1e-6);
  // Without scenes, the nodes no other node holds are the roots: the same.
  const TriMesh rootless = with(nodes, nullptr);
  EXPECT_EQ(rootless.positions, placed.positions);
  // The same placement as one column-major matrix: (x, y, z) -> (5 - 2y, 2x, 2z).
  const TriMesh by_matrix =
      with({{{"matrix", {0, 2, 0, 0, -2, 0, 0, 0, 0, 0, 2, 0, 5, 0, 0, 1}}, {"mesh", 0}}}, {0});
  ASSERT_EQ(by_matrix.positions.size(), 4u);
  for (int v = 0; v < 4; ++v)
    for (int a = 0; a < 3; ++a)
      EXPECT_NEAR(by_matrix.positions[v][a], expected[v][a], 1e-6) << v << " " << a;
  // A mirror (scale -1 along x): the faces keep facing out (positive volume), and so do the
  // normals.
  const TriMesh mirrored = with({{{"scale", {-1, 1, 1}}, {"mesh", 0}}}, {0});
  EXPECT_NEAR(fixtures::volume(mirrored), tetra, 1e-6);
  ASSERT_EQ(mirrored.normals.size(), 4u);
  for (int v = 0; v < 4; ++v) {
    double out = 0;
    for (int a = 0; a < 3; ++a)
      out += mirrored.normals[v][a] * (mirrored.positions[v][a] - (a == 0 ? -0.25 : 0.25));
    EXPECT_GT(out, 0) << "vertex " << v;
  }
  // No nodes: the mesh as it is.
  const TriMesh bare = with(nullptr, nullptr);
  EXPECT_EQ(bare.positions, tetrahedron().positions);
  EXPECT_EQ(bare.triangles, tetrahedron().triangles);
  // A hierarchy that is not a forest, a node that names no mesh: refused.
  EXPECT_TRUE(has(refusal([&] { with({{{"children", {0}}, {"mesh", 0}}}, {0}); }), "twice"));
  EXPECT_FALSE(refusal([&] { with({{{"mesh", 7}}}, {0}); }).empty());
}

TEST(Gltf, AGlbWhoseBinChunkClaimsItsOwnHeaderIsRefused) {
  // tinygltf 2.7 accepts this chunk and reads 8 bytes past the end of the file.
  const std::string glb =
      read_bytes(std::string(QJULIA_SOURCE_DIR) + "/tests/fuzz/corpus/glb/bin_chunk_past_end.glb");
  ASSERT_FALSE(glb.empty());
  EXPECT_EQ(refusal([&] { qjulia::read_mesh_from_memory(glb, MeshFormat::kGlb); }),
            "<memory>: the GLB is truncated (its BIN chunk reaches past the end)");
}

// ------------------------------------------------------------------------ 3MF

/// The 3MF writer's file with its model entry replaced by `model` (deflated by libzip).
std::string threemf_with_model(const TempDir& dir, const std::string& model) {
  const std::string path = dir.file("m.3mf");
  qjulia::write_mesh(path, tetrahedron());
  int err = 0;
  zip_t* z = zip_open(path.c_str(), 0, &err);
  EXPECT_NE(z, nullptr);
  zip_source_t* src = zip_source_buffer(z, model.data(), model.size(), 0);
  const zip_int64_t i = zip_name_locate(z, "3D/3dmodel.model", 0);
  EXPECT_GE(i, 0);
  EXPECT_EQ(zip_file_replace(z, zip_uint64_t(i), src, 0), 0);
  zip_set_file_compression(z, zip_uint64_t(i), ZIP_CM_DEFLATE, 9);
  EXPECT_EQ(zip_close(z), 0);
  return path;
}

/// Overwrites the uncompressed size of every entry in the zip's local and central headers
/// with `size` (what a zip bomb does to look small).
void understate_sizes(const std::string& path, uint32_t size) {
  std::string b = read_bytes(path);
  for (const std::string& sig : {std::string("PK\3\4"), std::string("PK\1\2")}) {
    const std::size_t field = sig[2] == 3 ? 22 : 24;
    for (std::size_t p = b.find(sig); p != std::string::npos; p = b.find(sig, p + 4))
      std::memcpy(&b[p + field], &size, 4);
  }
  write_bytes(path, b);
}

TEST(ThreeMf, DecompressingToMoreThanAHundredTimesTheFileIsRefusedEvenWhenHeadersUnderstateIt) {
  TempDir dir;
  const std::string head =
      R"(<?xml version="1.0" encoding="UTF-8"?><model unit="millimeter" xmlns="http://schemas.microsoft.com/3dmanufacturing/core/2015/02"><resources><object id="1" type="model"><mesh><vertices>)";
  const std::string tail =
      R"(<vertex x="0" y="0" z="0"/><vertex x="1" y="0" z="0"/><vertex x="0" y="1" z="0"/></vertices><triangles><triangle v1="0" v2="1" v3="2"/></triangles></mesh></object></resources><build><item objectid="1"/></build></model>)";
  // Readable: the same model with some padding.
  EXPECT_EQ(qjulia::read_mesh(threemf_with_model(dir, head + std::string(1000, ' ') + tail))
                .triangles.size(),
            1u);
  // 30 MB of a comment compress to some 30 kB.
  const std::string bomb =
      threemf_with_model(dir, head + "<!--" + std::string(30 << 20, '-') + "-->" + tail);
  EXPECT_LT(fs::file_size(bomb), 100000u);
  const std::string msg = refusal([&] { qjulia::read_mesh(bomb); });
  EXPECT_EQ(msg.rfind(bomb + ": refused: the archive decompresses to more than ", 0), 0u) << msg;
  EXPECT_TRUE(has(msg, "100 times its size")) << msg;
  understate_sizes(bomb, 1000);
  EXPECT_TRUE(has(refusal([&] { qjulia::read_mesh(bomb); }), "refused: the archive"));
}

// What a 3MF prints is its build: each item's object placed by the item's transform, a
// components object by its components' transforms too (slicers write both), a mirror with its
// faces kept outward; an object the build does not name is not read.
TEST(ThreeMf, TheBuildPlacesItsObjects) {
  TempDir dir;
  const std::string tetra =
      "<mesh><vertices><vertex x=\"0\" y=\"0\" z=\"0\"/><vertex x=\"1\" y=\"0\" z=\"0\"/>"
      "<vertex x=\"0\" y=\"1\" z=\"0\"/><vertex x=\"0\" y=\"0\" z=\"1\"/></vertices>"
      "<triangles><triangle v1=\"0\" v2=\"2\" v3=\"1\"/><triangle v1=\"0\" v2=\"1\" "
      "v3=\"3\"/><triangle v1=\"0\" v2=\"3\" v3=\"2\"/><triangle v1=\"1\" v2=\"2\" "
      "v3=\"3\"/></triangles></mesh>";
  // Object 1 a tetrahedron; object 2 two copies of it, one moved by (0, 10, 0) and mirrored in
  // x; object 3 (not built) a tetrahedron. The build: object 1 scaled by 2 and moved by
  // (5, 0, 0), object 2 as it is. 3MF's transform is "m00 m01 m02 m10 m11 m12 m20 m21 m22 m30
  // m31 m32", applied as (x, y, z, 1) times that 4 x 3 matrix.
  const std::string model =
      "<?xml version=\"1.0\" encoding=\"utf-8\"?><model unit=\"millimeter\" "
      "xmlns=\"http://schemas.microsoft.com/3dmanufacturing/core/2015/02\"><resources>"
      "<object id=\"1\" type=\"model\">" +
      tetra +
      "</object>"
      "<object id=\"2\" type=\"model\"><components><component objectid=\"1\"/>"
      "<component objectid=\"1\" transform=\"-1 0 0 0 1 0 0 0 1 0 10 0\"/></components></object>"
      "<object id=\"3\" type=\"model\">" +
      tetra +
      "</object>"
      "</resources><build><item objectid=\"1\" transform=\"2 0 0 0 2 0 0 0 2 5 0 0\"/>"
      "<item objectid=\"2\"/></build></model>";
  const TriMesh m = qjulia::read_mesh(threemf_with_model(dir, model));
  ASSERT_EQ(m.positions.size(), 12u);
  ASSERT_EQ(m.triangles.size(), 12u);
  const std::array<float, 3> moved[4] = {{5, 0, 0}, {7, 0, 0}, {5, 2, 0}, {5, 0, 2}};
  const std::array<float, 3> mirrored[4] = {{0, 10, 0}, {-1, 10, 0}, {0, 11, 0}, {0, 10, 1}};
  for (int v = 0; v < 4; ++v) {
    EXPECT_EQ(m.positions[v], moved[v]) << v;
    EXPECT_EQ(m.positions[4 + v], tetrahedron().positions[v]) << v;
    EXPECT_EQ(m.positions[8 + v], mirrored[v]) << v;
  }
  // Every copy faces out: 8/6 + 1/6 + 1/6.
  EXPECT_NEAR(fixtures::volume(m), 10.0 / 6, 1e-6);
}

// lib3mf walks every path down nested components when it reads a file: 40 objects that each
// place the one below twice (2^39 copies of one tetrahedron, in 4 KB) kept it busy for ever.
// Refused before lib3mf sees the file, as are components in a cycle; a few levels are read.
TEST(ThreeMf, ComponentsNestedIntoMillionsOfCopiesOrACycleAreRefusedAtOnce) {
  TempDir dir;
  auto model = [](int levels, bool cycle) {
    std::string s =
        "<?xml version=\"1.0\" encoding=\"utf-8\"?><model unit=\"millimeter\" "
        "xmlns=\"http://schemas.microsoft.com/3dmanufacturing/core/2015/02\"><resources>"
        "<object id=\"1\" type=\"model\"><mesh><vertices><vertex x=\"0\" y=\"0\" z=\"0\"/>"
        "<vertex x=\"1\" y=\"0\" z=\"0\"/><vertex x=\"0\" y=\"1\" z=\"0\"/>"
        "<vertex x=\"0\" y=\"0\" z=\"1\"/></vertices><triangles><triangle v1=\"0\" "
        "v2=\"2\" v3=\"1\"/><triangle v1=\"0\" v2=\"1\" v3=\"3\"/><triangle v1=\"0\" "
        "v2=\"3\" v3=\"2\"/><triangle v1=\"1\" v2=\"2\" v3=\"3\"/></triangles></mesh>"
        "</object>";
    for (int i = 2; i <= levels; ++i) {
      const std::string below = std::to_string(cycle && i == levels ? levels : i - 1);
      s += "<object id=\"" + std::to_string(i) + "\" type=\"model\"><components>" +
           "<component objectid=\"" + below + "\"/><component objectid=\"" + std::to_string(i - 1) +
           "\" transform=\"1 0 0 0 1 0 0 0 1 2 0 0\"/>" + "</components></object>";
    }
    return s + "</resources><build><item objectid=\"" + std::to_string(levels) +
           "\"/></build></model>";
  };
  const auto started = std::chrono::steady_clock::now();
  EXPECT_TRUE(has(refusal([&] { qjulia::read_mesh(threemf_with_model(dir, model(40, false))); }),
                  "nests components into more than 1000000 copies of its meshes"));
  EXPECT_TRUE(has(refusal([&] { qjulia::read_mesh(threemf_with_model(dir, model(5, true))); }),
                  "components that place each other in a cycle"));
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count(), 10);
  // Four levels: 8 copies, side by side.
  const TriMesh eight = qjulia::read_mesh(threemf_with_model(dir, model(4, false)));
  EXPECT_EQ(eight.triangles.size(), 32u);
  EXPECT_NEAR(fixtures::volume(eight), 8.0 / 6, 1e-6);
}

TEST(ThreeMf, WhitespaceThatOverflowsLib3mfsXmlReaderIsRefused) {
  // lib3mf 1.8 records every whitespace character between an attribute's name and its '=' in
  // arrays of its 64 KiB buffer's size, unchecked: these well-formed models crashed the reader
  // (SIGSEGV, or glibc's "double free or corruption"); mesh_3mf_fuzz found the first kind.
  TempDir dir;
  const std::string head = R"(<?xml version="1.0" encoding="UTF-8"?><model unit="millimeter" )";
  const std::string rest =
      R"(xmlns="http://schemas.microsoft.com/3dmanufacturing/core/2015/02"><resources><object id="1" type="model"><mesh><vertices><vertex x="0" y="0" z="0"/><vertex x="1" y="0" z="0"/><vertex x="0" y="1" z="0"/></vertices><triangles><triangle v1="0" v2="1" v3="2"/></triangles></mesh></object></resources><build><item objectid="1"/></build></model>)";
  const std::string one_run = threemf_with_model(
      dir, head + R"(xmlns:p="urn:x" p:q)" + std::string(32768, ' ') + R"(="1" )" + rest);
  const std::string msg = refusal([&] { qjulia::read_mesh(one_run); });
  EXPECT_EQ(msg, one_run +
                     ": refused: the part '3D/3dmodel.model' holds more than 4096 whitespace "
                     "characters in a row (lib3mf, which reads 3MF files, overflows its memory "
                     "on such XML)");
  std::string attributes;
  for (int i = 0; i < 12; ++i) {
    const std::string p = "p" + std::to_string(i);
    attributes += "xmlns:" + p + R"(="urn:x" )" + p + ":q" + std::string(4000, ' ') + R"(="1" )";
  }
  const std::string many = threemf_with_model(dir, head + attributes + rest);
  EXPECT_TRUE(has(refusal([&] { qjulia::read_mesh(many); }),
                  "holds more than 4096 whitespace characters before '=' signs"));
  // 4096 blanks in a row between elements, and a few before an '=' in text, are read.
  const std::string fine = threemf_with_model(
      dir, head + rest.substr(0, rest.find("<resources>")) + std::string(4096, '\n') +
               "<metadata name=\"x\">a  = b</metadata>" + rest.substr(rest.find("<resources>")));
  EXPECT_EQ(qjulia::read_mesh(fine).triangles.size(), 1u);
}

// ------------------------------------------------------------------------ writers

TEST(Writers, StopBetweenBlocksWhenTheTokenIsSetAndLeaveNoFile) {
  // The progress callback sets the token after write_mesh has begun: the writer itself must
  // notice it (between the blocks it writes), not the entry check.
  const TriMesh mesh = fixtures::icosphere(3);
  for (const auto& ext : kExtensions) {
    TempDir dir;
    qjulia::CancelToken token;
    qjulia::ExportOptions opts;
    opts.progress = [&](double f) {
      if (f == 0.0) token.request();
      return true;
    };
    opts.cancel = &token;
    EXPECT_THROW(qjulia::write_mesh(dir.file("m" + ext), mesh, opts), qjulia::Cancelled) << ext;
    EXPECT_TRUE(dir.names().empty()) << ext << ": " << dir.names().front();
  }
}

// The binary writers make the records that fit in the file's stage in parallel: the bytes must
// not depend on the threads (a mesh of 328k faces spans several stages in PLY and STL).
TEST(Writers, TheirBytesDoNotDependOnTheThreads) {
  const TriMesh mesh = fixtures::icosphere(7);
  ASSERT_GT(mesh.triangles.size(), 300000u);
  for (const auto& ext : kExtensions) {
    std::string bytes[2];
    for (int threads : {1, 2}) {
      TempDir dir;  // one name in both (a .gltf names its .bin)
      const std::string path = dir.file("m" + ext);
      tbb::task_arena(threads).execute([&] { qjulia::write_mesh(path, mesh); });
      bytes[threads - 1] = read_bytes(path);
    }
    EXPECT_FALSE(bytes[0].empty()) << ext;
    EXPECT_TRUE(bytes[0] == bytes[1]) << ext;
  }
}

// ------------------------------------------------------------------------ fuzz regressions

TEST(FuzzRegressions, EveryInputThatOnceFailedIsReadOrRefusedCleanly) {
  // Inputs the fuzzers found (tests/fuzz/regressions/TARGET/), read as their target reads them.
  const fs::path root = fs::path(QJULIA_SOURCE_DIR) / "tests/fuzz/regressions";
  const std::vector<std::pair<std::string, MeshFormat>> targets = {
      {"ply_ascii", MeshFormat::kPly},
      {"ply_binary_le", MeshFormat::kPly},
      {"ply_binary_be", MeshFormat::kPly},
      {"obj", MeshFormat::kObj},
      {"stl_ascii", MeshFormat::kStl},
      {"stl_binary", MeshFormat::kStl},
      {"gltf", MeshFormat::kGltf},
      {"glb", MeshFormat::kGlb},
      {"3mf", MeshFormat::k3mf}};
  std::size_t inputs = 0;
  for (const auto& [target, format] : targets) {
    if (!fs::is_directory(root / target)) continue;
    for (const auto& e : fs::directory_iterator(root / target)) {
      ++inputs;
      try {
        const TriMesh m = qjulia::read_mesh_from_memory(read_bytes(e.path()), format);
        EXPECT_NO_THROW(qjulia::validate_mesh(m, e.path().string(), {true}));
      } catch (const InvalidInput&) {
      }
    }
  }
  std::cout << inputs << " regression inputs\n";
}

}  // namespace
