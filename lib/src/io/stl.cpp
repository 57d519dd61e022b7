// STL. Writer: binary, an 80-byte header naming qjulia and the unit, one face normal per
// triangle. Reader: binary or ASCII, corners welded by position into an indexed mesh.
#include <cmath>
#include <cstring>

#include "base/geometry.h"
#include "base/weld.h"
#include "io/formats.h"
#include "io/records.h"
#include "io/text.h"
#include "qjulia/base/atomic_file.h"
#include "qjulia/base/error.h"

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__,
              "the STL writer and reader assume a little-endian host");

namespace qjulia::detail {
namespace {

constexpr std::size_t kHeader = 84;              // 80 bytes of text, a 32-bit triangle count
constexpr std::size_t kRecord = kStlFaceRecord;  // normal, three corners, 16-bit attribute

/// Unit normal of triangle (a, b, c) by the cross product, or zero when it has no area.
std::array<float, 3> face_normal(const std::array<float, 3>& a, const std::array<float, 3>& b,
                                 const std::array<float, 3>& c) {
  const Vec3d n = cross(to_vec3d(b) - to_vec3d(a), to_vec3d(c) - to_vec3d(a));
  const double len = length(n);
  if (!(len > 0) || !std::isfinite(len)) return {0, 0, 0};
  return {float(n[0] / len), float(n[1] / len), float(n[2] / len)};
}

}  // namespace

std::string stl_header(const ExportData& data, std::uint32_t count) {
  // The header must not start with "solid" (readers would take the file for ASCII STL).
  const std::string text = data.generator + " binary STL, unit: " +
                           (data.unit.empty() ? std::string("model units") : data.unit);
  std::string header(80, ' ');
  std::memcpy(header.data(), text.data(), std::min(text.size(), header.size()));
  header.append(reinterpret_cast<const char*>(&count), 4);
  return header;
}

void put_stl_face(char* p, const std::array<float, 3>& a, const std::array<float, 3>& b,
                  const std::array<float, 3>& c) {
  const auto n = face_normal(a, b, c);
  std::memcpy(p, n.data(), 12);
  std::memcpy(p + 12, a.data(), 12);
  std::memcpy(p + 24, b.data(), 12);
  std::memcpy(p + 36, c.data(), 12);
  p[48] = p[49] = 0;
}

void write_stl(const std::string& path, const ExportData& data) {
  const TriMesh& mesh = data.mesh;
  // Binary STL counts its triangles in 32 bits.
  if (mesh.triangles.size() > UINT32_MAX)
    throw InvalidInput(path + ": the mesh has " + std::to_string(mesh.triangles.size()) +
                       " faces, more than binary STL's 32-bit count holds; write .obj");
  AtomicFile file(path, data.cancel);
  BufferedWriter out(file);
  out.put(stl_header(data, uint32_t(mesh.triangles.size())));
  put_records(out, mesh.triangles.size(), kStlFaceRecord, [&](char* p, std::size_t f) {
    const auto& t = mesh.triangles[f];
    put_stl_face(p, mesh.positions[t[0]], mesh.positions[t[1]], mesh.positions[t[2]]);
  });
  out.flush();
  file.commit();
}

namespace {

/// Merges corners with bit-identical positions (after -0 -> +0): `corners` holds 3 positions
/// per triangle; fills mesh.positions and mesh.triangles.
void weld_corners(const std::vector<std::array<float, 3>>& corners, TriMesh& mesh,
                  ReadContext& ctx) {
  const std::size_t n = corners.size();
  ctx.charge(weld_table_slots(n), sizeof(uint32_t), "the welding table");
  ctx.charge(n / 3, 12, "triangles");
  mesh.triangles.resize(n / 3);
  // The corners' numbers go straight into the triangles (three to a triangle).
  static_assert(sizeof(std::array<uint32_t, 3>) == 3 * sizeof(uint32_t));
  auto* index = reinterpret_cast<uint32_t*>(mesh.triangles.data());
  const std::size_t distinct = number_positions(corners.data(), n, index);
  ctx.charge(distinct, 12, "vertex positions");
  mesh.positions.resize(distinct);
  first_positions(corners.data(), n, index, mesh.positions.data());
}

void read_binary_corners(std::string_view data, std::vector<std::array<float, 3>>& corners,
                         ReadContext& ctx) {
  uint32_t count = 0;
  std::memcpy(&count, data.data() + 80, 4);
  ctx.charge(std::size_t(count) * 3, 12, "triangle corners");
  corners.resize(std::size_t(count) * 3);
  const char* p = data.data() + kHeader;
  for (std::size_t t = 0; t < count; ++t, p += kRecord)
    std::memcpy(corners[3 * t].data(), p + 12, 36);
}

void read_ascii_corners(std::string_view text, std::vector<std::array<float, 3>>& corners,
                        ReadContext& ctx) {
  Lines lines(text);
  LineCursor c{nullptr, nullptr};
  while (lines.next(c)) {
    if (c.word() != "vertex") continue;
    std::array<float, 3> v;
    for (auto& x : v)
      if (!c.number(x)) ctx.fail(lines.where() + "expected three numbers after 'vertex'");
    push_charged(corners, v, ctx, "triangle corners");
  }
  if (corners.size() % 3 != 0)
    ctx.fail("the ASCII STL is truncated (vertex count not a multiple of 3)");
}

}  // namespace

TriMesh read_stl(std::string_view data, ReadContext& ctx) {
  uint32_t count = 0;
  if (data.size() >= kHeader) std::memcpy(&count, data.data() + 80, 4);
  const bool binary = data.size() >= kHeader && kHeader + kRecord * count == data.size();
  const std::size_t first = data.find_first_not_of(" \t\r\n");
  const bool ascii = !binary && first != std::string_view::npos && data.substr(first, 5) == "solid";
  std::vector<std::array<float, 3>> corners;
  if (binary) {
    read_binary_corners(data, corners, ctx);
  } else if (ascii) {
    read_ascii_corners(data.substr(first), corners, ctx);
  } else if (data.size() < kHeader) {
    ctx.fail("too short to be an STL file (" + std::to_string(data.size()) + " bytes)");
  } else {
    ctx.fail("truncated or not an STL file: the binary header says " + std::to_string(count) +
             " triangles (" + std::to_string(kHeader + kRecord * count) + " bytes), the file has " +
             std::to_string(data.size()) + " bytes");
  }
  if (corners.empty()) ctx.fail("the STL file has no triangles");
  TriMesh mesh;
  weld_corners(corners, mesh, ctx);
  return mesh;
}

}  // namespace qjulia::detail
