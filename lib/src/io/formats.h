#pragma once
/// @file formats.h
/// Internals of the io stage: one reader and one writer per format (gltf.cpp, obj.cpp,
/// ply.cpp, stl.cpp, threemf.cpp), and what they share. mesh_io.cpp checks the input, dispatches
/// here and checks what the readers return.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "qjulia/base/mesh.h"
#include "qjulia/io/mesh_io.h"

namespace qjulia::detail {

/// What every writer receives: the checked mesh, unit normals for every vertex, colours
/// clamped to [0, 1] (or empty), and the parameters pretty-printed (or empty).
struct ExportData {
  /// The normals written: the mesh's own when each is unit length to 1e-6 (no copy, so a mesh
  /// from the pipeline is not duplicated), else `made`.
  struct Normals {
    const std::array<float, 3>* p = nullptr;
    std::size_t n = 0;
    const std::array<float, 3>& operator[](std::size_t i) const { return p[i]; }
    const std::array<float, 3>* data() const { return p; }
    std::size_t size() const { return n; }
  };
  const TriMesh& mesh;
  Normals normals;                                 ///< #V unit vectors
  std::vector<std::array<float, 3>> made_normals;  ///< where `normals` points unless the mesh's
  std::vector<std::array<float, 3>> colors;   ///< empty or #V linear RGB in [0, 1]
  std::string params_json;                    ///< the parameters as pretty JSON, or empty
  std::vector<std::string> params_lines;      ///< params_json split at newlines
  std::string unit;                           ///< ExportOptions::unit
  std::string generator;                      ///< "qjulia VERSION"
  const CancelToken* cancel = nullptr;        ///< checked between blocks written
};

/// The ExportData of `mesh` for `path` (parameters checked and split, normals made unit length,
/// colours clamped), as write_mesh() gives it to the writers. With `make_normals` false, a mesh
/// without normals gets none (data.normals empty): the writer makes them (write_ply()).
ExportData export_data(const std::string& path, const TriMesh& mesh, const ExportOptions& opts,
                       bool make_normals = true);

/// The pieces of the binary PLY and STL files, for write_ply(), write_stl() and the ranks of a
/// distributed run, which write the same bytes in parts.
std::string ply_header(const ExportData& data, std::size_t vertices, std::size_t faces);
inline std::size_t ply_vertex_record(const ExportData& data) {
  return data.colors.empty() ? 24 : 27;
}
constexpr std::size_t kPlyFaceRecord = 13;
/// The record of vertex v of data.mesh.
void put_ply_vertex(char* p, const ExportData& data, std::size_t v);
void put_ply_face(char* p, const std::array<std::uint32_t, 3>& t);
/// The 80-byte header and the triangle count.
std::string stl_header(const ExportData& data, std::uint32_t count);
constexpr std::size_t kStlFaceRecord = 50;
void put_stl_face(char* p, const std::array<float, 3>& a, const std::array<float, 3>& b,
                  const std::array<float, 3>& c);

void write_gltf(const std::string& path, const ExportData& data, bool binary);
void write_obj(const std::string& path, const ExportData& data);
/// Makes the normals when `data` has none (area_weighted_normals()); meanwhile, when the run may
/// use two threads and the face section has kPlyAheadLeast bytes or more after its first aligned
/// byte, that part goes to the disk by threads of its own (RegionWriter). The bytes are the
/// same either way.
void write_ply(const std::string& path, ExportData& data);
constexpr std::uint64_t kPlyAheadLeast = std::uint64_t{16} << 20;
/// Bytes [first, first + n) of the face section of a binary PLY of `mesh`.
void put_ply_face_bytes(const TriMesh& mesh, std::uint64_t first, std::size_t n, char* out);
void write_stl(const std::string& path, const ExportData& data);
void write_3mf(const std::string& path, const ExportData& data);

/// What a reader knows about its input and the memory it may use. Readers check every count
/// in a file against the bytes that hold it, then charge() what they allocate, before they
/// allocate it.
class ReadContext {
 public:
  /// @param name          names the input in messages (the path, or ReadOptions::name)
  /// @param base_dir      the folder of the file, where a .gltf's buffers are; "" when the
  ///                      bytes come from memory (then only data: URIs are read)
  /// @param memory_limit  bytes the reader may allocate in all
  /// @param limit_text    describes the limit in messages ("4.0 GiB (MemAvailable)")
  ReadContext(std::string name, std::string base_dir, std::size_t memory_limit,
              std::string limit_text);

  const std::string& name() const { return name_; }
  const std::string& base_dir() const { return base_dir_; }
  /// Throws InvalidInput("NAME: " + reason).
  [[noreturn]] void fail(const std::string& reason) const;
  /// Counts `bytes` more against the limit. @throws TooLarge naming `what` when they do not fit.
  void charge(std::size_t bytes, const std::string& what);
  /// `count` items of `size` bytes, with the product checked for overflow.
  void charge(std::size_t count, std::size_t size, const std::string& what);
  /// Gives back `bytes` charged before (a block that was freed).
  void release(std::size_t bytes) { charged_ -= std::min(bytes, charged_); }
  std::size_t remaining() const { return limit_ - charged_; }

 private:
  std::string name_;
  std::string base_dir_;
  std::size_t limit_;
  std::string limit_text_;
  std::size_t charged_ = 0;
};

/// Makes room for `needed` items in `v` (doubling), charging the new block while the old one
/// still exists (the peak of a reallocation), then releasing the old one.
template <class T>
void reserve_charged(std::vector<T>& v, std::size_t needed, ReadContext& ctx, const char* what) {
  if (needed <= v.capacity()) return;
  const std::size_t old = v.capacity();
  const std::size_t cap = std::max(needed, std::max<std::size_t>(1024, 2 * old));
  ctx.charge(cap, sizeof(T), what);
  v.reserve(cap);
  ctx.release(old * sizeof(T));
}

/// Appends `item` to `v`, charging the context whenever the vector must grow.
template <class T>
void push_charged(std::vector<T>& v, const T& item, ReadContext& ctx, const char* what) {
  if (v.size() == v.capacity()) reserve_charged(v, v.size() + 1, ctx, what);
  v.push_back(item);
}

/// Parses `bytes` in `format`, checks the mesh (validate_mesh) and applies the readers' policy
/// (ReadReport): what read_mesh() and read_mesh_from_memory() do, and the fuzzers call.
/// @throws InvalidInput naming ctx.name(); TooLarge.
TriMesh read_mesh_bytes(std::string_view bytes, MeshFormat format, ReadContext& ctx,
                        ReadReport* report);

// Readers: parse the whole file in `bytes`. Each returns the mesh as the file holds it; the
// caller (read_mesh) checks it with validate_mesh() and applies the policy of ReadReport.
TriMesh read_gltf(std::string_view bytes, bool binary, ReadContext& ctx);
TriMesh read_obj(std::string_view bytes, ReadContext& ctx);
TriMesh read_ply(std::string_view bytes, ReadContext& ctx);
TriMesh read_stl(std::string_view bytes, ReadContext& ctx);
TriMesh read_3mf(std::string_view bytes, ReadContext& ctx);

std::string read_gltf_params(std::string_view bytes, bool binary, const ReadContext& ctx);
std::string read_3mf_params(std::string_view bytes, ReadContext& ctx);
std::string read_obj_params(std::string_view bytes);
std::string read_ply_params(std::string_view bytes);

/// The comment prefix that marks parameter lines in OBJ ("# params ") and PLY ("params ").
inline constexpr const char* kParamsTag = "params ";

/// sRGB transfer function (IEC 61966-2-1) for 8-bit/text colour formats (PLY, OBJ).
inline float linear_to_srgb(float c) {
  return c <= 0.0031308f ? 12.92f * c : 1.055f * std::pow(c, 1.0f / 2.4f) - 0.055f;
}
inline float srgb_to_linear(float c) {
  return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f);
}

}  // namespace qjulia::detail
