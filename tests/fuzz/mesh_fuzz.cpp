// libFuzzer target of one mesh reader, chosen by QJULIA_FUZZ_TARGET (tests/fuzz/CMakeLists.txt
// builds one executable per reader). Any byte string must either read as a mesh that passes
// the library's checks, or throw qjulia::InvalidInput (TooLarge included) naming the input;
// anything else (another exception, a crash, a leak, a sanitizer report) is a bug. Inputs that
// belong to another target (a PLY of another encoding, an STL of the other kind) are rejected
// (-1), so each corpus stays its own. Run by scripts/fuzz.sh.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <string_view>

#include "io/formats.h"
#include "qjulia/base/error.h"

#define QJULIA_FUZZ_ply_ascii 1
#define QJULIA_FUZZ_ply_binary_le 2
#define QJULIA_FUZZ_ply_binary_be 3
#define QJULIA_FUZZ_obj 4
#define QJULIA_FUZZ_stl_ascii 5
#define QJULIA_FUZZ_stl_binary 6
#define QJULIA_FUZZ_gltf 7
#define QJULIA_FUZZ_glb 8
#define QJULIA_FUZZ_3mf 9

namespace {

using qjulia::MeshFormat;

#if QJULIA_FUZZ_TARGET <= QJULIA_FUZZ_ply_binary_be
constexpr MeshFormat kFormat = MeshFormat::kPly;
#elif QJULIA_FUZZ_TARGET == QJULIA_FUZZ_obj
constexpr MeshFormat kFormat = MeshFormat::kObj;
#elif QJULIA_FUZZ_TARGET <= QJULIA_FUZZ_stl_binary
constexpr MeshFormat kFormat = MeshFormat::kStl;
#elif QJULIA_FUZZ_TARGET == QJULIA_FUZZ_gltf
constexpr MeshFormat kFormat = MeshFormat::kGltf;
#elif QJULIA_FUZZ_TARGET == QJULIA_FUZZ_glb
constexpr MeshFormat kFormat = MeshFormat::kGlb;
#else
constexpr MeshFormat kFormat = MeshFormat::k3mf;
#endif

/// Whether `bytes` belongs to this target's corpus.
bool belongs(std::string_view bytes) {
#if QJULIA_FUZZ_TARGET <= QJULIA_FUZZ_ply_binary_be
  const char* formats[] = {"ascii", "binary_little_endian", "binary_big_endian"};
  const std::string line = std::string("format ") + formats[QJULIA_FUZZ_TARGET - 1] + " ";
  return bytes.substr(0, 400).find(line) != std::string_view::npos;
#elif QJULIA_FUZZ_TARGET <= QJULIA_FUZZ_stl_binary
  const auto first = bytes.find_first_not_of(" \t\r\n");
  const bool ascii = first != std::string_view::npos && bytes.substr(first, 5) == "solid";
  return ascii == (QJULIA_FUZZ_TARGET == QJULIA_FUZZ_stl_ascii);
#else
  (void)bytes;
  return true;
#endif
}

[[noreturn]] void bug(const char* what) {
  std::fprintf(stderr, "mesh fuzz: %s\n", what);
  std::abort();
}

/// What the readers promise for every mesh they return.
void check(const qjulia::TriMesh& m, const qjulia::ReadReport& report) {
  const std::size_t nv = m.positions.size();
  if (m.triangles.empty()) bug("a mesh without triangles was returned");
  for (const auto& t : m.triangles) {
    if (t[0] >= nv || t[1] >= nv || t[2] >= nv) bug("an index is out of range");
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) bug("a repeated index was kept");
  }
  for (const auto& p : m.positions)
    if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2]))
      bug("a non-finite position was returned");
  if (!m.normals.empty() && m.normals.size() != nv) bug("normals do not match the vertices");
  if (!m.colors.empty() && m.colors.size() != nv) bug("colours do not match the vertices");
  if (report.unreferenced_vertices > nv) bug("more unreferenced vertices than vertices");
}

void read_params(std::string_view bytes, qjulia::detail::ReadContext& ctx) {
  using namespace qjulia::detail;
  switch (kFormat) {
    case MeshFormat::kGlb:
    case MeshFormat::kGltf:
      read_gltf_params(bytes, kFormat == MeshFormat::kGlb, ctx);
      break;
    case MeshFormat::kObj:
      read_obj_params(bytes);
      break;
    case MeshFormat::kPly:
      read_ply_params(bytes);
      break;
    case MeshFormat::kStl:
      break;
    case MeshFormat::k3mf:
      read_3mf_params(bytes, ctx);
      break;
  }
}

constexpr std::size_t kMemory = std::size_t(256) << 20;  // well below libFuzzer's -rss_limit_mb

/// Runs `read` on a fresh context: it may return or throw InvalidInput naming the input.
template <class F>
void expect_clean(const char* what, F&& read) {
  qjulia::detail::ReadContext ctx("fuzz", "", kMemory, "256 MiB (fuzzing)");
  try {
    read(ctx);
  } catch (const qjulia::InvalidInput& e) {
    if (std::strncmp(e.what(), "fuzz: ", 6) != 0) bug("a message that does not name the input");
  } catch (const std::exception& e) {
    std::fprintf(stderr, "mesh fuzz: unexpected exception reading %s: %s\n", what, e.what());
    std::abort();
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  if (!belongs(bytes)) return -1;
  // From memory: a .gltf may use data: URIs only, and the limit is fixed (deterministic).
  expect_clean("the mesh", [&](qjulia::detail::ReadContext& ctx) {
    qjulia::ReadReport report;
    check(qjulia::detail::read_mesh_bytes(bytes, kFormat, ctx, &report), report);
  });
  expect_clean("the parameters",
               [&](qjulia::detail::ReadContext& ctx) { read_params(bytes, ctx); });
  return 0;
}
