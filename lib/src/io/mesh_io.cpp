// The export stage's front door: format by extension, input checks, normals, dispatch.
#include "qjulia/io/mesh_io.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>
#include <unordered_map>

#include "io/formats.h"
#include "qjulia/base/error.h"

namespace qjulia {
namespace detail {

[[noreturn]] void fail(const std::string& path, const std::string& reason) {
  throw InvalidInput(path + ": " + reason);
}

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path, std::string("cannot read the file (") + std::strerror(errno) + ")");
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  if (size < 0) fail(path, "cannot read the file (not a regular file)");
  std::string data(static_cast<std::size_t>(size), '\0');
  in.seekg(0);
  if (!in.read(data.data(), size)) fail(path, "cannot read the file (read error)");
  return data;
}

std::array<float, 3> face_normal(const std::array<float, 3>& a, const std::array<float, 3>& b,
                                 const std::array<float, 3>& c) {
  const double u[3] = {double(b[0]) - a[0], double(b[1]) - a[1], double(b[2]) - a[2]};
  const double v[3] = {double(c[0]) - a[0], double(c[1]) - a[1], double(c[2]) - a[2]};
  const double n[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2],
                       u[0] * v[1] - u[1] * v[0]};
  const double len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
  if (!(len > 0) || !std::isfinite(len)) return {0, 0, 0};
  return {float(n[0] / len), float(n[1] / len), float(n[2] / len)};
}

void weld_corners(const std::vector<std::array<float, 3>>& corners, TriMesh& mesh) {
  // Open addressing on the bit patterns: several times faster than std::unordered_map on
  // millions of corners.
  const std::size_t n = corners.size();
  std::size_t cap = 16;
  while (cap < n + n / 2) cap <<= 1;
  std::vector<uint32_t> table(cap, UINT32_MAX);
  mesh.positions.clear();
  mesh.positions.reserve(n / 5 + 16);
  mesh.triangles.resize(n / 3);
  auto key_of = [](const std::array<float, 3>& p) {
    std::array<uint32_t, 3> k;
    for (int i = 0; i < 3; ++i) {
      const float f = p[i] == 0.0f ? 0.0f : p[i];  // -0 and +0 are one position
      std::memcpy(&k[i], &f, 4);
    }
    return k;
  };
  for (std::size_t c = 0; c < n; ++c) {
    const auto k = key_of(corners[c]);
    uint64_t h = (uint64_t(k[0]) * 0x9E3779B97F4A7C15ull) ^
                 (uint64_t(k[1]) * 0xC2B2AE3D27D4EB4Full) ^
                 (uint64_t(k[2]) * 0x165667B19E3779F9ull);
    h ^= h >> 29;
    std::size_t slot = h & (cap - 1);
    uint32_t index;
    for (;;) {
      const uint32_t e = table[slot];
      if (e == UINT32_MAX) {
        index = uint32_t(mesh.positions.size());
        const float* f = reinterpret_cast<const float*>(k.data());
        mesh.positions.push_back({f[0], f[1], f[2]});
        table[slot] = index;
        break;
      }
      if (key_of(mesh.positions[e]) == k) {
        index = e;
        break;
      }
      slot = (slot + 1) & (cap - 1);
    }
    mesh.triangles[c / 3][c % 3] = index;
  }
}

namespace {

/// Unit normals for every vertex: the given ones where they are finite and non-zero, otherwise
/// area-weighted face normals; (0, 0, 1) where nothing defines a direction.
std::vector<std::array<float, 3>> unit_normals(const TriMesh& mesh) {
  const std::size_t nv = mesh.positions.size();
  std::vector<std::array<float, 3>> computed;  // made only when a given normal is unusable
  std::vector<std::array<float, 3>> out(nv);
  const bool given = mesh.normals.size() == nv;
  for (std::size_t v = 0; v < nv; ++v) {
    if (given) {
      const auto& g = mesh.normals[v];
      const double len = std::sqrt(double(g[0]) * g[0] + double(g[1]) * g[1] + double(g[2]) * g[2]);
      if (len > 1e-300 && std::isfinite(len)) {
        out[v] = {float(g[0] / len), float(g[1] / len), float(g[2] / len)};
        continue;
      }
    }
    if (computed.empty()) computed = area_weighted_normals(mesh);
    out[v] = computed[v];
  }
  return out;
}

void check_mesh(const std::string& path, const TriMesh& mesh) {
  const std::size_t nv = mesh.positions.size();
  if (mesh.triangles.empty()) {
    throw InvalidInput(path + ": the mesh is empty (0 triangles); nothing to write");
  }
  if (nv >= UINT32_MAX) throw InvalidInput(path + ": too many vertices for 32-bit indices");
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
    const auto& t = mesh.triangles[f];
    if (t[0] >= nv || t[1] >= nv || t[2] >= nv) {
      throw InvalidInput(path + ": triangle " + std::to_string(f) + " has vertex index " +
                         std::to_string(std::max({t[0], t[1], t[2]})) + " but the mesh has " +
                         std::to_string(nv) + " vertices");
    }
  }
  for (std::size_t v = 0; v < nv; ++v) {
    const auto& p = mesh.positions[v];
    if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2])) {
      throw InvalidInput(path + ": vertex " + std::to_string(v) + " has a non-finite position");
    }
  }
  if (!mesh.normals.empty() && mesh.normals.size() != nv) {
    throw InvalidInput(path + ": the mesh has " + std::to_string(mesh.normals.size()) +
                       " normals for " + std::to_string(nv) + " vertices");
  }
  if (!mesh.colors.empty() && mesh.colors.size() != nv) {
    throw InvalidInput(path + ": the mesh has " + std::to_string(mesh.colors.size()) +
                       " colours for " + std::to_string(nv) + " vertices");
  }
}

std::string lower_extension(const std::string& path) {
  const auto slash = path.find_last_of('/');
  const auto dot = path.find_last_of('.');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return "";
  std::string ext = path.substr(dot);
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return char(std::tolower(c)); });
  return ext;
}

}  // namespace
}  // namespace detail

MeshFormat format_from_path(const std::string& path) {
  const std::string ext = detail::lower_extension(path);
  if (ext == ".glb") return MeshFormat::kGlb;
  if (ext == ".gltf") return MeshFormat::kGltf;
  if (ext == ".obj") return MeshFormat::kObj;
  if (ext == ".ply") return MeshFormat::kPly;
  if (ext == ".stl") return MeshFormat::kStl;
  if (ext == ".3mf") return MeshFormat::k3mf;
  const std::string shown = ext.empty() ? std::string("no extension") : "'" + ext + "'";
  throw InvalidInput(path + ": unknown output format " + shown +
                     " (use .glb, .gltf, .obj, .ply, .stl or .3mf)");
}

std::vector<std::string> output_files(const std::string& path) {
  if (format_from_path(path) != MeshFormat::kGltf) return {path};
  return {path, path.substr(0, path.find_last_of('.')) + ".bin"};
}

const char* extension_of(MeshFormat format) {
  switch (format) {
    case MeshFormat::kGlb:
      return ".glb";
    case MeshFormat::kGltf:
      return ".gltf";
    case MeshFormat::kObj:
      return ".obj";
    case MeshFormat::kPly:
      return ".ply";
    case MeshFormat::kStl:
      return ".stl";
    case MeshFormat::k3mf:
      return ".3mf";
  }
  return "";
}

void write_mesh(const std::string& path, const TriMesh& mesh, const ExportOptions& opts) {
  const MeshFormat format = format_from_path(path);
  detail::check_mesh(path, mesh);
  if (opts.progress && !opts.progress(0.0)) throw Cancelled();

  detail::ExportData data{mesh, {}, {}, {}, {}, opts.unit, std::string("qjulia ") + QJULIA_VERSION};
  if (!opts.params_json.empty()) {
    nlohmann::ordered_json params;
    try {
      params = nlohmann::ordered_json::parse(opts.params_json);
    } catch (const nlohmann::json::exception& e) {
      throw InvalidInput(path + ": the parameters to record are not valid JSON (" + e.what() + ")");
    }
    data.params_json = params.dump(2);
    std::size_t start = 0;
    for (;;) {
      const auto nl = data.params_json.find('\n', start);
      data.params_lines.push_back(data.params_json.substr(start, nl - start));
      if (nl == std::string::npos) break;
      start = nl + 1;
    }
  }
  data.normals = detail::unit_normals(mesh);
  if (!mesh.colors.empty()) {
    data.colors.resize(mesh.colors.size());
    for (std::size_t v = 0; v < mesh.colors.size(); ++v)
      for (int i = 0; i < 3; ++i) {
        const float c = mesh.colors[v][i];
        data.colors[v][i] = std::isfinite(c) ? std::clamp(c, 0.0f, 1.0f) : 0.0f;
      }
  }

  switch (format) {
    case MeshFormat::kGlb:
      detail::write_gltf(path, data, true);
      break;
    case MeshFormat::kGltf:
      detail::write_gltf(path, data, false);
      break;
    case MeshFormat::kObj:
      detail::write_obj(path, data);
      break;
    case MeshFormat::kPly:
      detail::write_ply(path, data);
      break;
    case MeshFormat::kStl:
      detail::write_stl(path, data);
      break;
    case MeshFormat::k3mf:
      detail::write_3mf(path, data);
      break;
  }
  if (opts.progress) opts.progress(1.0);
}

namespace {
MeshFormat input_format(const std::string& path) {
  try {
    return format_from_path(path);
  } catch (const InvalidInput&) {
    const std::string ext = detail::lower_extension(path);
    throw InvalidInput(path + ": unknown mesh format " +
                       (ext.empty() ? std::string("(no extension)") : "'" + ext + "'") +
                       " (readable: .glb, .gltf, .obj, .ply, .stl, .3mf)");
  }
}
}  // namespace

TriMesh read_mesh(const std::string& path) {
  switch (input_format(path)) {
    case MeshFormat::kGlb:
      return detail::read_gltf(path, true);
    case MeshFormat::kGltf:
      return detail::read_gltf(path, false);
    case MeshFormat::kObj:
      return detail::read_obj(path);
    case MeshFormat::kPly:
      return detail::read_ply(path);
    case MeshFormat::kStl:
      return detail::read_stl(path);
    case MeshFormat::k3mf:
      return detail::read_3mf(path);
  }
  return {};
}

std::string read_mesh_params(const std::string& path) {
  switch (input_format(path)) {
    case MeshFormat::kGlb:
      return detail::read_gltf_params(path, true);
    case MeshFormat::kGltf:
      return detail::read_gltf_params(path, false);
    case MeshFormat::kObj:
      return detail::read_obj_params(path);
    case MeshFormat::kPly:
      return detail::read_ply_params(path);
    case MeshFormat::kStl:
      detail::read_file(path);
      return "";
    case MeshFormat::k3mf:
      return detail::read_3mf_params(path);
  }
  return "";
}

}  // namespace qjulia
