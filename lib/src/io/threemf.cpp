// 3MF, writer and reader, through lib3mf in the module libqjulia_3mf.so (threemf_module.h): the
// file's content UUIDs, its path and the memory a read may take are decided here.
#include <cstdint>
#include <memory>

#include "base/hash.h"
#include "io/formats.h"
#include "io/threemf_module.h"
#include "qjulia/base/atomic_file.h"
#include "qjulia/base/error.h"

namespace qjulia::detail {
namespace {

/// A UUID (RFC 9562 version 8, "custom") made from `h` and `salt`: 3MF names the object, the
/// build and the build item by UUIDs, which lib3mf would otherwise draw at random, so the same
/// mesh and parameters would give different bytes on every run.
std::string content_uuid(std::uint64_t h, std::uint64_t salt) {
  const std::uint64_t hi = splitmix64(h ^ splitmix64(salt));
  const std::uint64_t lo = splitmix64(hi ^ h);
  unsigned char b[16];
  for (int i = 0; i < 8; ++i) {
    b[i] = static_cast<unsigned char>(hi >> (56 - 8 * i));
    b[8 + i] = static_cast<unsigned char>(lo >> (56 - 8 * i));
  }
  b[6] = static_cast<unsigned char>((b[6] & 0x0f) | 0x80);  // version 8
  b[8] = static_cast<unsigned char>((b[8] & 0x3f) | 0x80);  // variant 10
  static const char kHex[] = "0123456789abcdef";
  std::string out;
  for (int i = 0; i < 16; ++i) {
    if (i == 4 || i == 6 || i == 8 || i == 10) out += '-';
    out += kHex[b[i] >> 4];
    out += kHex[b[i] & 15];
  }
  return out;
}

/// A hash of everything the file holds: the same mesh, parameters and unit give the same UUIDs
/// (and so the same bytes), any change gives others.
std::uint64_t content_hash(const ExportData& data) {
  std::uint64_t h = 0;
  h = hash_bytes(h, data.generator.data(), data.generator.size());
  h = hash_bytes(h, data.unit.data(), data.unit.size());
  h = hash_bytes(h, data.params_json.data(), data.params_json.size());
  h = hash_bytes(h, data.mesh.positions.data(), data.mesh.positions.size() * sizeof(float) * 3);
  h = hash_bytes(h, data.mesh.triangles.data(),
                 data.mesh.triangles.size() * sizeof(std::uint32_t) * 3);
  return h;
}

bool keep_going(void* token) { return !static_cast<const CancelToken*>(token)->requested(); }

/// A parsed model, released by the module.
struct Model {
  const ThreeMfApi& api;
  void* handle = nullptr;
  ~Model() { api.close(handle); }
};

/// Scans and parses `bytes` (the model charged to `ctx`: lib3mf parses the XML as it streams,
/// and its model takes about as much as the XML).
std::unique_ptr<Model> load(std::string_view bytes, ReadContext& ctx) {
  const ThreeMfApi& api = threemf_api();
  std::size_t decompressed = 0;
  std::string why = api.scan(bytes, decompressed);
  if (!why.empty()) ctx.fail(why);
  ctx.charge(decompressed, "the 3MF model");
  auto model = std::make_unique<Model>(Model{api});
  model->handle = api.open(bytes, why);
  if (!model->handle) ctx.fail(why);
  return model;
}

}  // namespace

void write_3mf(const std::string& path, const ExportData& data) {
  const ThreeMfApi& api = threemf_api();
  const TriMesh& mesh = data.mesh;
  ThreeMfWrite in;
  in.positions = mesh.positions.data();
  in.vertices = mesh.positions.size();
  in.triangles = mesh.triangles.data();
  in.faces = mesh.triangles.size();
  in.unit = data.unit;
  in.generator = data.generator;
  in.params = data.params_json;
  const std::uint64_t h = content_hash(data);
  for (int k = 0; k < 3; ++k) in.uuid[k] = content_uuid(h, k + 1);
  if (data.cancel) {
    in.keep_going = keep_going;
    in.token = const_cast<CancelToken*>(data.cancel);
  }
  AtomicFile file(path, data.cancel);  // checks the path before the work
  std::string bytes;
  const std::string why = api.write(in, bytes);
  if (!why.empty()) {
    throw_if_cancelled(data.cancel);
    throw std::runtime_error(path + ": " + why);
  }
  file.write(bytes);
  file.commit();
}

TriMesh read_3mf(std::string_view bytes, ReadContext& ctx) {
  const std::unique_ptr<Model> model = load(bytes, ctx);
  std::vector<std::array<std::size_t, 2>> sizes;
  std::string why = model->api.sizes(model->handle, sizes);
  if (!why.empty()) ctx.fail(why);
  std::size_t vertices = 0, faces = 0;
  for (const auto& s : sizes) {
    vertices += s[0];
    faces += s[1];
  }
  TriMesh mesh;
  reserve_charged(mesh.positions, vertices, ctx, "vertices");
  reserve_charged(mesh.triangles, faces, ctx, "triangles");
  mesh.positions.resize(vertices);
  mesh.triangles.resize(faces);
  why = model->api.mesh(model->handle, mesh.positions.data(), mesh.triangles.data());
  if (!why.empty()) ctx.fail(why);
  if (mesh.triangles.empty()) ctx.fail("the 3MF file has no triangles");
  return mesh;
}

std::string read_3mf_params(std::string_view bytes, ReadContext& ctx) {
  const std::unique_ptr<Model> model = load(bytes, ctx);
  std::string value;
  const std::string why = model->api.description(model->handle, value);
  if (!why.empty()) ctx.fail(why);
  return value;
}

}  // namespace qjulia::detail
