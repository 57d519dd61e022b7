// The io stage's front door: the format by extension, the input check, normals and colours
// for the writers, the file read whole, and the one check of every mesh a reader returns.
#include "qjulia/io/mesh_io.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <nlohmann/json.hpp>

#include "base/all_of.h"
#include "io/formats.h"
#include "qjulia/base/error.h"
#include "qjulia/base/memory.h"
#include "qjulia/base/validate.h"

namespace qjulia {
namespace detail {

ReadContext::ReadContext(std::string name, std::string base_dir, std::size_t memory_limit,
                         std::string limit_text)
    : name_(std::move(name)),
      base_dir_(std::move(base_dir)),
      limit_(memory_limit),
      limit_text_(std::move(limit_text)) {}

void ReadContext::fail(const std::string& reason) const {
  throw InvalidInput(name_ + ": " + reason);
}

void ReadContext::charge(std::size_t bytes, const std::string& what) {
  if (bytes > limit_ - charged_) {
    const double need = double(charged_) + double(bytes);
    throw TooLarge(name_ + ": reading it needs at least " + format_bytes(need) + " (" + what +
                   "), more than the " + limit_text_ + " it may use");
  }
  charged_ += bytes;
}

void ReadContext::charge(std::size_t count, std::size_t size, const std::string& what) {
  if (size != 0 && count > SIZE_MAX / size) charge(SIZE_MAX, what);
  charge(count * size, what);
}

namespace {

/// Whether every normal has unit length (in parallel: every mesh written is checked).
bool all_unit(const std::vector<std::array<float, 3>>& normals) {
  return detail::all_of_parallel(normals.size(), [&](std::size_t v) {
    const auto& g = normals[v];
    const double len2 = double(g[0]) * g[0] + double(g[1]) * g[1] + double(g[2]) * g[2];
    return std::abs(len2 - 1.0) < 1e-6;  // false for NaN too
  });
}

/// Unit normals for every vertex: the given ones, normalized, where they are finite and non-zero,
/// otherwise area-weighted face normals; (0, 0, 1) where nothing defines a direction.
std::vector<std::array<float, 3>> unit_normals(const TriMesh& mesh) {
  const std::size_t nv = mesh.positions.size();
  if (mesh.normals.size() != nv) return area_weighted_normals(mesh);  // none given
  std::vector<std::array<float, 3>> computed;  // made only when a given normal is unusable
  std::vector<std::array<float, 3>> out(nv);
  for (std::size_t v = 0; v < nv; ++v) {
    const auto& g = mesh.normals[v];
    const double len = std::sqrt(double(g[0]) * g[0] + double(g[1]) * g[1] + double(g[2]) * g[2]);
    if (len > 1e-300 && std::isfinite(len)) {
      out[v] = {float(g[0] / len), float(g[1] / len), float(g[2] / len)};
      continue;
    }
    if (computed.empty()) computed = area_weighted_normals(mesh);
    out[v] = computed[v];
  }
  return out;
}

/// The parameters pretty-printed and split into lines.
void set_params(const std::string& path, const std::string& params_json, ExportData& data) {
  if (params_json.empty()) return;
  nlohmann::ordered_json params;
  try {
    params = nlohmann::ordered_json::parse(params_json);
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

std::string lower_extension(const std::string& path) {
  const auto slash = path.find_last_of('/');
  const auto dot = path.find_last_of('.');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return "";
  std::string ext = path.substr(dot);
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return char(std::tolower(c)); });
  return ext;
}

MeshFormat input_format(const std::string& path) {
  try {
    return format_from_path(path);
  } catch (const InvalidInput&) {
    const std::string ext = lower_extension(path);
    throw InvalidInput(path +
                       (ext.empty() ? std::string(": the mesh format follows the file's "
                                                  "extension, and it has none")
                                    : ": unknown mesh format '" + ext + "'") +
                       " (readable: .glb, .gltf, .obj, .ply, .stl, .3mf)");
  }
}

/// A reader's context for the file `path` and the limits of `opts`.
ReadContext file_context(const std::string& path, const ReadOptions& opts) {
  const auto slash = path.find_last_of('/');
  std::string dir = slash == std::string::npos ? "." : path.substr(0, slash);
  if (dir.empty()) dir = "/";
  const MemoryLimits limits = memory_limits(opts.max_memory);
  return ReadContext(path, dir, limits.effective(), limits.describe());
}

/// The whole file, charged to `ctx` before it is allocated. Only a regular file is read (a
/// FIFO would block, a device never ends).
std::string read_whole_file(const std::string& path, ReadContext& ctx) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) ctx.fail(std::string("cannot read the file (") + std::strerror(errno) + ")");
  struct Closer {
    int fd;
    ~Closer() { ::close(fd); }
  } closer{fd};
  struct stat st;
  if (::fstat(fd, &st) != 0)
    ctx.fail(std::string("cannot read the file (") + std::strerror(errno) + ")");
  if (!S_ISREG(st.st_mode)) ctx.fail("cannot read the file (not a regular file)");
  const std::size_t size = std::size_t(st.st_size);
  ctx.charge(size, "the file");
  std::string data(size, '\0');
  std::size_t done = 0;
  while (done < size) {
    const ssize_t n = ::read(fd, data.data() + done, size - done);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) ctx.fail(std::string("cannot read the file (") + std::strerror(errno) + ")");
    if (n == 0) ctx.fail("cannot read the file (it shrank while it was read)");
    done += std::size_t(n);
  }
  return data;
}

TriMesh parse(std::string_view bytes, MeshFormat format, ReadContext& ctx) {
  switch (format) {
    case MeshFormat::kGlb:
      return read_gltf(bytes, true, ctx);
    case MeshFormat::kGltf:
      return read_gltf(bytes, false, ctx);
    case MeshFormat::kObj:
      return read_obj(bytes, ctx);
    case MeshFormat::kPly:
      return read_ply(bytes, ctx);
    case MeshFormat::kStl:
      return read_stl(bytes, ctx);
    case MeshFormat::k3mf:
      return read_3mf(bytes, ctx);
  }
  return {};
}

/// The policy of every reader: the mesh is checked (validate_mesh), triangles with a repeated
/// index are dropped, unreferenced vertices kept.
void finish_read(TriMesh& mesh, const ReadContext& ctx, ReadReport* report) {
  validate_mesh(mesh, ctx.name());
  ReadReport rep;
  auto& tris = mesh.triangles;
  const auto kept = std::remove_if(tris.begin(), tris.end(), [](const auto& t) {
    return t[0] == t[1] || t[1] == t[2] || t[0] == t[2];
  });
  rep.dropped_faces = std::size_t(tris.end() - kept);
  tris.erase(kept, tris.end());
  if (tris.empty()) {
    ctx.fail(rep.dropped_faces ? "every triangle has a repeated vertex index (no area)"
                               : "the file has no triangles");
  }
  if (report) {
    std::vector<char> used(mesh.positions.size(), 0);
    for (const auto& t : tris) used[t[0]] = used[t[1]] = used[t[2]] = 1;
    rep.unreferenced_vertices = std::size_t(std::count(used.begin(), used.end(), 0));
    *report = rep;
  }
}

}  // namespace

TriMesh read_mesh_bytes(std::string_view bytes, MeshFormat format, ReadContext& ctx,
                        ReadReport* report) {
  TriMesh mesh = parse(bytes, format, ctx);
  finish_read(mesh, ctx, report);
  return mesh;
}

}  // namespace detail

MeshFormat format_from_path(const std::string& path) {
  const std::string ext = detail::lower_extension(path);
  if (ext == ".glb") return MeshFormat::kGlb;
  if (ext == ".gltf") return MeshFormat::kGltf;
  if (ext == ".obj") return MeshFormat::kObj;
  if (ext == ".ply") return MeshFormat::kPly;
  if (ext == ".stl") return MeshFormat::kStl;
  if (ext == ".3mf") return MeshFormat::k3mf;
  if (ext.empty())
    throw InvalidInput(path +
                       ": the output format follows the file's extension, and it has none (use "
                       ".glb, .gltf, .obj, .ply, .stl or .3mf)");
  throw InvalidInput(path + ": unknown output format '" + ext +
                     "' (use .glb, .gltf, .obj, .ply, .stl or .3mf)");
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

namespace detail {

ExportData export_data(const std::string& path, const TriMesh& mesh, const ExportOptions& opts,
                       bool make_normals) {
  ExportData data{
      mesh, {}, {}, {}, {}, {}, opts.unit, std::string("qjulia ") + QJULIA_VERSION, opts.cancel};
  set_params(path, opts.params_json, data);
  const std::size_t nv = mesh.positions.size();
  const bool unit = mesh.normals.size() == nv && all_unit(mesh.normals);
  if (unit) {
    data.normals = {mesh.normals.data(), nv};
  } else if (make_normals || !mesh.normals.empty()) {
    data.made_normals = unit_normals(mesh);
    data.normals = {data.made_normals.data(), nv};
  }
  if (!mesh.colors.empty()) {
    data.colors.resize(mesh.colors.size());
    for (std::size_t v = 0; v < mesh.colors.size(); ++v)
      for (int i = 0; i < 3; ++i) {
        const float c = mesh.colors[v][i];
        data.colors[v][i] = std::isfinite(c) ? std::clamp(c, 0.0f, 1.0f) : 0.0f;
      }
  }
  return data;
}

}  // namespace detail

void write_mesh(const std::string& path, const TriMesh& mesh, const ExportOptions& opts) {
  const MeshFormat format = format_from_path(path);
  validate_mesh(mesh, path, {/*faces=*/true});
  throw_if_cancelled(opts.cancel);
  if (opts.progress && !opts.progress(0.0)) throw Cancelled();

  // A PLY writer makes missing normals itself, while its faces are written.
  detail::ExportData data = detail::export_data(path, mesh, opts, format != MeshFormat::kPly);

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

TriMesh read_mesh(const std::string& path, const ReadOptions& opts) {
  const MeshFormat format = detail::input_format(path);
  detail::ReadContext ctx = detail::file_context(path, opts);
  const std::string bytes = detail::read_whole_file(path, ctx);
  return detail::read_mesh_bytes(bytes, format, ctx, opts.report);
}

TriMesh read_mesh_from_memory(std::string_view bytes, MeshFormat format, const ReadOptions& opts) {
  const MemoryLimits limits = memory_limits(opts.max_memory);
  detail::ReadContext ctx(opts.name.empty() ? "<memory>" : opts.name, "", limits.effective(),
                          limits.describe());
  return detail::read_mesh_bytes(bytes, format, ctx, opts.report);
}

std::string read_mesh_params(const std::string& path) {
  const MeshFormat format = detail::input_format(path);
  detail::ReadContext ctx = detail::file_context(path, {});
  const std::string bytes = detail::read_whole_file(path, ctx);
  switch (format) {
    case MeshFormat::kGlb:
      return detail::read_gltf_params(bytes, true, ctx);
    case MeshFormat::kGltf:
      return detail::read_gltf_params(bytes, false, ctx);
    case MeshFormat::kObj:
      return detail::read_obj_params(bytes);
    case MeshFormat::kPly:
      return detail::read_ply_params(bytes);
    case MeshFormat::kStl:
      return "";
    case MeshFormat::k3mf:
      return detail::read_3mf_params(bytes, ctx);
  }
  return "";
}

}  // namespace qjulia
