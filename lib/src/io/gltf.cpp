// glTF 2.0 (.glb and .gltf + .bin) through tinygltf, writer and reader. The only file that
// includes tiny_gltf.h.
#include <sys/stat.h>
#include <tiny_gltf.h>

#include <array>
#include <climits>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "base/placement.h"
#include "io/formats.h"
#include "qjulia/base/atomic_file.h"
#include "qjulia/base/error.h"

namespace qjulia::detail {
namespace {

static_assert(sizeof(std::array<float, 3>) == 12 && sizeof(std::array<uint32_t, 3>) == 12,
              "the mesh arrays are written as they lie in memory");

constexpr uint32_t kGlbMagic = 0x46546C67;  // "glTF"
constexpr uint32_t kChunkJson = 0x4E4F534A;
constexpr uint32_t kChunkBin = 0x004E4942;

std::string file_name(const std::string& path) {
  const auto slash = path.find_last_of('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

std::string bin_path_for(const std::string& gltf_path) {
  const auto dot = gltf_path.find_last_of('.');
  return gltf_path.substr(0, dot) + ".bin";
}

/// Percent-encodes everything outside RFC 3986's unreserved characters.
std::string uri_encode(const std::string& s) {
  static const char* hex = "0123456789ABCDEF";
  std::string out;
  for (unsigned char c : s) {
    if (std::isalnum(c) || c == '-' || c == '_' || c == '.' || c == '~') {
      out += char(c);
    } else {
      out += '%';
      out += hex[c >> 4];
      out += hex[c & 15];
    }
  }
  return out;
}

struct Span {
  const void* data;
  std::size_t size;
};

/// The binary buffer: indices, positions, normals, colours (when present), back to back.
std::vector<Span> buffer_chunks(const ExportData& data) {
  const TriMesh& mesh = data.mesh;
  const std::size_t nv = mesh.positions.size();
  std::vector<Span> chunks = {{mesh.triangles.data(), mesh.triangles.size() * 12},
                              {mesh.positions.data(), nv * 12},
                              {data.normals.data(), nv * 12}};
  if (!data.colors.empty()) chunks.push_back({data.colors.data(), nv * 12});
  return chunks;
}

/// Buffer views and accessors of the chunks; returns the buffer's size.
std::size_t add_accessors(tinygltf::Model& model, const ExportData& data,
                          const std::vector<Span>& chunks, tinygltf::Primitive& primitive) {
  const TriMesh& mesh = data.mesh;
  std::size_t offset = 0;
  for (std::size_t i = 0; i < chunks.size(); ++i) {
    tinygltf::BufferView view;
    view.buffer = 0;
    view.byteOffset = offset;
    view.byteLength = chunks[i].size;
    view.target = i == 0 ? TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER : TINYGLTF_TARGET_ARRAY_BUFFER;
    model.bufferViews.push_back(view);
    offset += chunks[i].size;
  }
  auto add_accessor = [&](int view, int component, int type, std::size_t count) {
    tinygltf::Accessor a;
    a.bufferView = view;
    a.byteOffset = 0;
    a.componentType = component;
    a.type = type;
    a.count = count;
    model.accessors.push_back(a);
    return int(model.accessors.size() - 1);
  };
  const std::size_t nv = mesh.positions.size();
  primitive.indices = add_accessor(0, TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT, TINYGLTF_TYPE_SCALAR,
                                   mesh.triangles.size() * 3);
  const int position = add_accessor(1, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, nv);
  // The validator requires min/max to equal the data's exactly (as float32).
  std::array<float, 3> lo = mesh.positions[0], hi = mesh.positions[0];
  for (const auto& p : mesh.positions)
    for (int i = 0; i < 3; ++i) {
      lo[i] = std::min(lo[i], p[i]);
      hi[i] = std::max(hi[i], p[i]);
    }
  model.accessors[position].minValues = {lo[0], lo[1], lo[2]};
  model.accessors[position].maxValues = {hi[0], hi[1], hi[2]};
  primitive.attributes["POSITION"] = position;
  primitive.attributes["NORMAL"] =
      add_accessor(2, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, nv);
  if (chunks.size() > 3) {
    primitive.attributes["COLOR_0"] =
        add_accessor(3, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, nv);
  }
  return offset;
}

/// The material, mesh, node and scene around `primitive`.
void add_scene(tinygltf::Model& model, tinygltf::Primitive primitive) {
  // White base colour times COLOR_0: Blender's importer and web viewers then show the colours.
  tinygltf::Material material;
  material.name = "qjulia";
  material.pbrMetallicRoughness.baseColorFactor = {1.0, 1.0, 1.0, 1.0};
  material.pbrMetallicRoughness.metallicFactor = 0.0;
  material.pbrMetallicRoughness.roughnessFactor = 0.6;
  material.doubleSided = false;
  model.materials.push_back(material);

  primitive.mode = TINYGLTF_MODE_TRIANGLES;
  primitive.material = 0;
  tinygltf::Mesh gmesh;
  gmesh.name = "qjulia";
  gmesh.primitives.push_back(primitive);
  model.meshes.push_back(gmesh);

  tinygltf::Node node;  // no transform: coordinates stay as sampled
  node.mesh = 0;
  node.name = "qjulia";
  model.nodes.push_back(node);
  tinygltf::Scene scene;
  scene.nodes.push_back(0);
  model.scenes.push_back(scene);
  model.defaultScene = 0;
}

/// The glTF JSON document of `data`, whose buffer has `total` bytes.
nlohmann::ordered_json document(const std::string& path, const ExportData& data,
                                const std::vector<Span>& chunks, bool binary) {
  tinygltf::Model model;
  model.asset.version = "2.0";
  model.asset.generator = data.generator;
  model.buffers.emplace_back();  // its data is written by us, straight from the mesh arrays
  tinygltf::Primitive primitive;
  const std::size_t total = add_accessors(model, data, chunks, primitive);
  if (total + 4096 > UINT32_MAX) {
    throw InvalidInput(path + ": the mesh is too big for glTF (buffer over 4 GB)");
  }
  add_scene(model, primitive);

  std::ostringstream json_stream;
  tinygltf::TinyGLTF gltf;
  if (!gltf.WriteGltfSceneToStream(&model, json_stream, !binary, false)) {
    throw std::runtime_error(path + ": tinygltf could not serialize the model");
  }
  // tinygltf would embed the buffer as base64 (or copy it); we patch in the real buffer entry
  // and write the bytes ourselves. asset.extras is set here too, from an order-preserving JSON
  // object, so the parameters read in the order they were written.
  nlohmann::ordered_json doc = nlohmann::ordered_json::parse(json_stream.str());
  nlohmann::ordered_json buf_json;
  buf_json["byteLength"] = total;
  if (!binary) buf_json["uri"] = uri_encode(file_name(bin_path_for(path)));
  doc["buffers"] = nlohmann::ordered_json::array({buf_json});
  if (!data.params_json.empty()) {
    doc["asset"]["extras"] = nlohmann::ordered_json::parse(data.params_json);
  }
  return doc;
}

std::size_t total_size(const std::vector<Span>& chunks) {
  std::size_t total = 0;
  for (const Span& c : chunks) total += c.size;
  return total;
}

void write_glb(const std::string& path, const nlohmann::ordered_json& doc,
               const std::vector<Span>& chunks, const CancelToken* cancel) {
  std::string json = doc.dump();
  while (json.size() % 4 != 0) json += ' ';
  const std::size_t total = total_size(chunks);
  const uint32_t header[3] = {kGlbMagic, 2, uint32_t(12 + 8 + json.size() + 8 + total)};
  const uint32_t json_head[2] = {uint32_t(json.size()), kChunkJson};
  const uint32_t bin_head[2] = {uint32_t(total), kChunkBin};
  AtomicFile out(path, cancel);
  out.write(header, sizeof header);
  out.write(json_head, sizeof json_head);
  out.write(json);
  out.write(bin_head, sizeof bin_head);
  for (const Span& c : chunks) out.write(c.data, c.size);
  out.commit();
}

void write_gltf_and_bin(const std::string& path, const nlohmann::ordered_json& doc,
                        const std::vector<Span>& chunks, const CancelToken* cancel) {
  const std::string bin_path = bin_path_for(path);
  AtomicFile bin(bin_path, cancel);
  for (const Span& c : chunks) bin.write(c.data, c.size);
  AtomicFile out(path, cancel);
  out.write(doc.dump(2) + "\n");
  bin.commit();
  try {
    out.commit();
  } catch (...) {
    std::remove(bin_path.c_str());
    throw;
  }
}

}  // namespace

void write_gltf(const std::string& path, const ExportData& data, bool binary) {
  const std::vector<Span> chunks = buffer_chunks(data);
  const nlohmann::ordered_json doc = document(path, data, chunks, binary);
  if (binary)
    write_glb(path, doc, chunks, data.cancel);
  else
    write_gltf_and_bin(path, doc, chunks, data.cancel);
}

// ---------------------------------------------------------------------------------- reader

namespace {

/// The parts of a GLB, checked against its size (tinygltf 2.7 reads 8 bytes past the end of
/// a file whose BIN chunk claims the bytes of its own header). The header's length must be the
/// file's (glTF 2.0, GLB header): bytes inserted into or cut from a file are refused, not read
/// as a shifted buffer.
struct GlbParts {
  std::string_view json;
  std::size_t length = 0;  ///< the GLB's own length (the bytes given to tinygltf)
};

GlbParts split_glb(std::string_view bytes, const ReadContext& ctx) {
  uint32_t head[5];
  if (bytes.size() < sizeof head) ctx.fail("not a GLB file (too short)");
  std::memcpy(head, bytes.data(), sizeof head);
  if (head[0] != kGlbMagic) ctx.fail("not a GLB file (no 'glTF' magic)");
  if (head[1] != 2) ctx.fail("GLB version " + std::to_string(head[1]) + " (only 2 is read)");
  const uint64_t length = head[2];
  const uint64_t json_end = 20 + uint64_t(head[3]);
  if (length != bytes.size()) {
    ctx.fail(std::string(length > bytes.size() ? "the GLB is truncated" : "not a valid GLB file") +
             " (its header says " + std::to_string(length) + " bytes, the file has " +
             std::to_string(bytes.size()) + ")");
  }
  if (head[4] != kChunkJson || head[3] == 0 || json_end > length) {
    ctx.fail("not a valid GLB file (its header says " + std::to_string(length) +
             " bytes and a JSON chunk of " + std::to_string(head[3]) + ", the file has " +
             std::to_string(bytes.size()) + ")");
  }
  if (json_end < length) {
    uint32_t bin[2] = {0, 0};
    if (json_end + 8 > length) ctx.fail("the GLB is truncated (a partial chunk header)");
    std::memcpy(bin, bytes.data() + json_end, 8);
    if (json_end + 8 + uint64_t(bin[0]) > length)
      ctx.fail("the GLB is truncated (its BIN chunk reaches past the end)");
  }
  return {bytes.substr(20, head[3]), std::size_t(length)};
}

/// Where a .gltf may read its buffers: regular files inside its own folder.
struct BufferPolicy {
  ReadContext* ctx;
  std::string prefix;     ///< base_dir + "/": every path tinygltf asks about must start so
  std::string real_base;  ///< realpath of the folder
  std::string refused;    ///< why the last file was refused
};

bool has_scheme(const std::string& uri) {
  const auto colon = uri.find(':');
  if (colon == std::string::npos || colon == 0) return false;
  for (std::size_t i = 0; i < colon; ++i) {
    const char c = uri[i];
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '+' && c != '-' && c != '.')
      return false;
  }
  return std::isalpha(static_cast<unsigned char>(uri[0]));
}

/// Why the file `rel` (relative to the folder) may not be read, or "" when it may.
std::string refusal(const BufferPolicy& p, const std::string& rel) {
  if (rel.empty()) return "is empty";
  if (rel.find('\0') != std::string::npos) return "holds a NUL character";
  if (rel[0] == '/') return "is an absolute path (only files beside the .gltf are read)";
  if (has_scheme(rel)) return "is a URI with a scheme (only data: URIs and files are read)";
  std::size_t start = 0;
  for (;;) {
    const std::size_t slash = rel.find('/', start);
    if (rel.compare(start, slash == std::string::npos ? std::string::npos : slash - start, "..") ==
        0)
      return "leaves the folder of the .gltf ('..')";
    if (slash == std::string::npos) break;
    start = slash + 1;
  }
  char real[PATH_MAX];
  const std::string full = p.prefix + rel;
  if (!::realpath(full.c_str(), real)) return "does not exist";
  const std::string inside = p.real_base == "/" ? "/" : p.real_base + "/";
  if (std::string(real).rfind(inside, 0) != 0)
    return "is a link leading out of the folder of the .gltf";
  struct stat st;
  if (::stat(real, &st) != 0 || !S_ISREG(st.st_mode)) return "is not a regular file";
  return "";
}

bool policy_file_exists(const std::string& path, void* user) {
  auto& p = *static_cast<BufferPolicy*>(user);
  if (p.ctx->base_dir().empty()) {  // tinygltf tries "URI", then "./URI"
    if (p.refused.empty()) {
      p.refused = "URI '" + path + "' names a file, but the glTF was read from memory (only " +
                  "data: URIs are read)";
    }
    return false;
  }
  if (path.rfind(p.prefix, 0) != 0) return false;  // tinygltf's second try, the working folder
  const std::string rel = path.substr(p.prefix.size());
  const std::string why = refusal(p, rel);
  if (!why.empty()) p.refused = "URI '" + rel + "' " + why;
  return why.empty();
}

std::string policy_expand(const std::string& path, void*) { return path; }

bool policy_read(std::vector<unsigned char>* out, std::string* err, const std::string& path,
                 void* user) {
  auto& p = *static_cast<BufferPolicy*>(user);
  if (!policy_file_exists(path, user)) {
    if (err) *err = p.refused;
    return false;
  }
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  const std::streamoff size = in ? std::streamoff(in.tellg()) : -1;
  if (size < 0) {
    p.refused = "buffer '" + path.substr(p.prefix.size()) + "' cannot be read";
    if (err) *err = p.refused;
    return false;
  }
  // TooLarge passes through tinygltf, which holds nothing but standard containers.
  p.ctx->charge(std::size_t(size), "buffer '" + path.substr(p.prefix.size()) + "'");
  out->resize(std::size_t(size));
  in.seekg(0);
  in.read(reinterpret_cast<char*>(out->data()), size);
  return bool(in);
}

bool policy_write(std::string*, const std::string&, const std::vector<unsigned char>&, void*) {
  return false;
}

/// Images are not part of the mesh: not decoded.
bool skip_image(tinygltf::Image*, const int, std::string*, std::string*, int, int,
                const unsigned char*, int, void*) {
  return true;
}

tinygltf::Model load(std::string_view bytes, bool binary, ReadContext& ctx) {
  if (bytes.size() >= UINT32_MAX) ctx.fail("too big for glTF (4 GiB or more)");
  const std::string& dir = ctx.base_dir();
  BufferPolicy policy{&ctx, dir.empty() || dir.back() == '/' ? dir : dir + "/", "", ""};
  if (!ctx.base_dir().empty()) {
    char real[PATH_MAX];
    if (!::realpath(ctx.base_dir().c_str(), real)) ctx.fail("its folder cannot be resolved");
    policy.real_base = real;
  }
  tinygltf::TinyGLTF loader;
  loader.SetFsCallbacks({policy_file_exists, policy_expand, policy_read, policy_write, &policy});
  loader.SetImageLoader(skip_image, nullptr);
  tinygltf::Model model;
  std::string err, warn;
  bool ok;
  if (binary) {
    const GlbParts parts = split_glb(bytes, ctx);
    ctx.charge(parts.length, "the GLB's buffers");
    ok = loader.LoadBinaryFromMemory(&model, &err, &warn,
                                     reinterpret_cast<const unsigned char*>(bytes.data()),
                                     unsigned(parts.length), ctx.base_dir());
  } else {
    ctx.charge(bytes.size(), "the glTF's buffers");
    ok = loader.LoadASCIIFromString(&model, &err, &warn, bytes.data(), unsigned(bytes.size()),
                                    ctx.base_dir());
  }
  if (!ok) {
    while (!err.empty() && (err.back() == '\n' || err.back() == ' ')) err.pop_back();
    for (auto& c : err)
      if (c == '\n') c = ' ';
    if (err.empty()) err = "tinygltf failed";
    if (!policy.refused.empty()) ctx.fail("refused: " + policy.refused + " (" + err + ")");
    ctx.fail("not a valid glTF file (" + err + ")");
  }
  return model;
}

/// Bytes of one component of `type`, for the types qjulia reads (0 for the others).
std::size_t component_size(int type) {
  switch (type) {
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
      return 1;
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT:
      return 2;
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
    case TINYGLTF_COMPONENT_TYPE_FLOAT:
      return 4;
  }
  return 0;
}

/// The bytes accessor `a` reads: checked against its view and buffer. Returns the first byte.
const unsigned char* accessor_bytes(const tinygltf::Model& m, const tinygltf::Accessor& a,
                                    std::size_t elem, std::size_t& stride, const std::string& what,
                                    const ReadContext& ctx) {
  if (a.bufferView < 0 || std::size_t(a.bufferView) >= m.bufferViews.size())
    ctx.fail(what + " accessor has no buffer view");
  const tinygltf::BufferView& v = m.bufferViews[a.bufferView];
  if (v.buffer < 0 || std::size_t(v.buffer) >= m.buffers.size())
    ctx.fail(what + " buffer view has no buffer");
  const auto& buf = m.buffers[v.buffer].data;
  stride = v.byteStride ? v.byteStride : elem;
  if (v.byteOffset > buf.size() || v.byteLength > buf.size() ||
      v.byteOffset + v.byteLength > buf.size() || a.count > v.byteLength || stride > 256 ||
      stride < elem || a.byteOffset > v.byteLength ||
      a.byteOffset + (a.count - 1) * stride + elem > v.byteLength) {
    ctx.fail(what + " accessor reaches past the end of its buffer (truncated file?)");
  }
  return buf.data() + v.byteOffset + a.byteOffset;
}

/// Reads accessor `index` as #count 3-vectors (float, or normalized ubyte/ushort; VEC4 drops
/// the fourth component).
std::vector<std::array<float, 3>> read_vec3(const tinygltf::Model& m, int index,
                                            const std::string& what, bool allow_vec4,
                                            ReadContext& ctx) {
  if (index < 0 || std::size_t(index) >= m.accessors.size()) ctx.fail(what + " accessor missing");
  const tinygltf::Accessor& a = m.accessors[index];
  if (a.sparse.isSparse) ctx.fail(what + ": sparse accessors are not supported");
  const int comps = a.type == TINYGLTF_TYPE_VEC3 ? 3 : a.type == TINYGLTF_TYPE_VEC4 ? 4 : 0;
  if (comps == 0 || (comps == 4 && !allow_vec4)) {
    ctx.fail(what + " accessor has type " + std::to_string(a.type) + " (expected VEC3" +
             (allow_vec4 ? " or VEC4)" : ")"));
  }
  const std::size_t csize = component_size(a.componentType);
  if (csize == 0 || a.componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT)
    ctx.fail(what + " accessor has an unsupported component type");
  if (csize != 4 && !a.normalized) ctx.fail(what + " integer accessor must be normalized");
  if (a.count == 0) return {};
  std::size_t stride = 0;
  const unsigned char* p = accessor_bytes(m, a, csize * comps, stride, what, ctx);
  ctx.charge(a.count, 12, what);
  std::vector<std::array<float, 3>> out(a.count);  // after the bounds check: count is trusted
  for (std::size_t i = 0; i < a.count; ++i, p += stride) {
    for (int k = 0; k < 3; ++k) {
      if (csize == 4) {
        std::memcpy(&out[i][k], p + 4 * k, 4);
      } else if (csize == 1) {
        out[i][k] = p[k] / 255.0f;
      } else {
        uint16_t s;
        std::memcpy(&s, p + 2 * k, 2);
        out[i][k] = s / 65535.0f;
      }
    }
  }
  return out;
}

std::vector<uint32_t> read_indices(const tinygltf::Model& m, int index, ReadContext& ctx) {
  if (index < 0 || std::size_t(index) >= m.accessors.size())
    ctx.fail("a primitive's index accessor is missing");
  const tinygltf::Accessor& a = m.accessors[index];
  if (a.type != TINYGLTF_TYPE_SCALAR || a.sparse.isSparse)
    ctx.fail("the index accessor is not a plain SCALAR");
  const std::size_t csize = component_size(a.componentType);
  if (csize == 0 || a.componentType == TINYGLTF_COMPONENT_TYPE_FLOAT)
    ctx.fail("the index accessor has an unsupported component type");
  if (a.count == 0) return {};
  std::size_t stride = 0;
  const unsigned char* p = accessor_bytes(m, a, csize, stride, "the index", ctx);
  ctx.charge(a.count, 4, "indices");
  std::vector<uint32_t> out(a.count);
  if (csize == 4 && stride == 4) {
    std::memcpy(out.data(), p, a.count * 4);
    return out;
  }
  for (std::size_t i = 0; i < a.count; ++i, p += stride) {
    if (csize == 1) {
      out[i] = *p;
    } else if (csize == 2) {
      uint16_t s;
      std::memcpy(&s, p, 2);
      out[i] = s;
    } else {
      std::memcpy(&out[i], p, 4);
    }
  }
  return out;
}

/// The mesh as it is read: every triangle primitive appended; normals and colours kept only
/// when every primitive has them.
struct GltfMesh {
  TriMesh mesh;
  bool all_normals = true, all_colors = true;
  std::vector<std::array<float, 3>> normals, colors;
};

/// An attribute of one primitive appended to `out` (cleared, and `all` false, when missing).
void append_attribute(const tinygltf::Model& model, const tinygltf::Primitive& prim,
                      const char* name, std::size_t count, bool allow_vec4,
                      std::vector<std::array<float, 3>>& out, bool& all, ReadContext& ctx) {
  const auto it = prim.attributes.find(name);
  if (!all || it == prim.attributes.end()) {
    all = false;
    out.clear();
    return;
  }
  const auto values = read_vec3(model, it->second, name, allow_vec4, ctx);
  if (values.size() != count) ctx.fail(std::string(name) + " and POSITION counts differ");
  reserve_charged(out, out.size() + values.size(), ctx, name);
  out.insert(out.end(), values.begin(), values.end());
}

/// A node's own transform: its matrix, or translation * rotation * scale.
Placement local_placement(const tinygltf::Node& n, ReadContext& ctx) {
  Placement m = kUnmoved;
  if (n.matrix.size() == 16) {
    // Column-major 4x4; its last row is (0, 0, 0, 1) in glTF.
    for (int col = 0; col < 4; ++col)
      for (int row = 0; row < 3; ++row) m[row * 4 + col] = n.matrix[std::size_t(col * 4 + row)];
  } else {
    if (!n.matrix.empty()) ctx.fail("a node's matrix does not have 16 numbers");
    if (!n.translation.empty() && n.translation.size() != 3)
      ctx.fail("a node's translation does not have 3 numbers");
    if (!n.rotation.empty() && n.rotation.size() != 4)
      ctx.fail("a node's rotation does not have 4 numbers");
    if (!n.scale.empty() && n.scale.size() != 3) ctx.fail("a node's scale does not have 3 numbers");
    const double x = n.rotation.empty() ? 0 : n.rotation[0],
                 y = n.rotation.empty() ? 0 : n.rotation[1],
                 z = n.rotation.empty() ? 0 : n.rotation[2],
                 w = n.rotation.empty() ? 1 : n.rotation[3];
    const double s[3] = {n.scale.empty() ? 1 : n.scale[0], n.scale.empty() ? 1 : n.scale[1],
                         n.scale.empty() ? 1 : n.scale[2]};
    // The rotation matrix of the unit quaternion (x, y, z, w), columns scaled.
    const double r[9] = {1 - 2 * (y * y + z * z), 2 * (x * y + z * w),     2 * (x * z - y * w),
                         2 * (x * y - z * w),     1 - 2 * (x * x + z * z), 2 * (y * z + x * w),
                         2 * (x * z + y * w),     2 * (y * z - x * w),     1 - 2 * (x * x + y * y)};
    for (int col = 0; col < 3; ++col)
      for (int row = 0; row < 3; ++row) m[row * 4 + col] = r[col * 3 + row] * s[col];
    for (int row = 0; row < 3; ++row)
      m[row * 4 + 3] = n.translation.empty() ? 0 : n.translation[row];
  }
  for (double v : m)
    if (!std::isfinite(v)) ctx.fail("a node's transform is not finite");
  return m;
}

void append_primitive(const tinygltf::Model& model, const tinygltf::Primitive& prim,
                      const Placement& place, GltfMesh& g, ReadContext& ctx) {
  const auto pos_it = prim.attributes.find("POSITION");
  if (pos_it == prim.attributes.end()) ctx.fail("a primitive has no POSITION");
  auto pos = read_vec3(model, pos_it->second, "POSITION", false, ctx);
  const bool moved = place != kUnmoved;
  if (moved) place_positions(place, pos.data(), pos.size());
  TriMesh& mesh = g.mesh;
  if (mesh.positions.size() + pos.size() >= UINT32_MAX) ctx.fail("too many vertices");
  const uint32_t base = uint32_t(mesh.positions.size());
  std::vector<uint32_t> idx;
  if (prim.indices >= 0) {
    idx = read_indices(model, prim.indices, ctx);
  } else {
    ctx.charge(pos.size(), 4, "indices");
    idx.resize(pos.size());
    for (std::size_t i = 0; i < idx.size(); ++i) idx[i] = uint32_t(i);
  }
  if (idx.size() % 3 != 0) ctx.fail("a triangle primitive's index count is not a multiple of 3");
  const std::size_t first_face = mesh.triangles.size();
  reserve_charged(mesh.triangles, mesh.triangles.size() + idx.size() / 3, ctx, "triangles");
  reserve_charged(mesh.positions, mesh.positions.size() + pos.size(), ctx, "vertices");
  for (std::size_t i = 0; i < idx.size(); i += 3) {
    for (int k = 0; k < 3; ++k)
      if (idx[i + k] >= pos.size()) {
        ctx.fail("index " + std::to_string(idx[i + k]) + " is out of range (" +
                 std::to_string(pos.size()) + " vertices)");
      }
    mesh.triangles.push_back({base + idx[i], base + idx[i + 1], base + idx[i + 2]});
  }
  keep_outward(place, mesh.triangles.data() + first_face, mesh.triangles.size() - first_face);
  mesh.positions.insert(mesh.positions.end(), pos.begin(), pos.end());
  const std::size_t first_normal = g.normals.size();
  append_attribute(model, prim, "NORMAL", pos.size(), false, g.normals, g.all_normals, ctx);
  if (moved && g.all_normals)
    place_normals(place, g.normals.data() + first_normal, g.normals.size() - first_normal);
  append_attribute(model, prim, "COLOR_0", pos.size(), true, g.colors, g.all_colors, ctx);
}

/// The triangle primitives of mesh `index`, placed by `place`.
void append_mesh(const tinygltf::Model& model, int index, const Placement& place, GltfMesh& g,
                 ReadContext& ctx) {
  if (index < 0 || std::size_t(index) >= model.meshes.size())
    ctx.fail("a node names mesh " + std::to_string(index) + ", which does not exist");
  for (const auto& prim : model.meshes[std::size_t(index)].primitives)
    if (prim.mode == -1 || prim.mode == TINYGLTF_MODE_TRIANGLES)
      append_primitive(model, prim, place, g, ctx);
}

/// The scene's meshes where its nodes place them: the default scene (or the first), or, in a
/// file without scenes, every node no other node holds. False when no node holds a mesh.
bool append_scene(const tinygltf::Model& model, GltfMesh& g, ReadContext& ctx) {
  const std::size_t nodes = model.nodes.size();
  std::vector<int> roots;
  if (!model.scenes.empty()) {
    const int s = model.defaultScene >= 0 ? model.defaultScene : 0;
    if (std::size_t(s) >= model.scenes.size()) ctx.fail("the default scene does not exist");
    roots = model.scenes[std::size_t(s)].nodes;
  } else {
    std::vector<char> child(nodes, 0);
    for (const auto& n : model.nodes)
      for (int c : n.children)
        if (c >= 0 && std::size_t(c) < nodes) child[std::size_t(c)] = 1;
    for (std::size_t i = 0; i < nodes; ++i)
      if (!child[i]) roots.push_back(int(i));
  }
  // Depth first; the hierarchy is a forest (glTF 2.0, 5.25), so a node met twice is an error
  // (and a cycle cannot loop).
  std::vector<char> seen(nodes, 0);
  std::vector<std::pair<int, Placement>> stack;
  for (auto it = roots.rbegin(); it != roots.rend(); ++it) stack.emplace_back(*it, kUnmoved);
  bool any = false;
  while (!stack.empty()) {
    const auto [index, parent] = stack.back();
    stack.pop_back();
    if (index < 0 || std::size_t(index) >= nodes)
      ctx.fail("node " + std::to_string(index) + " does not exist");
    if (seen[std::size_t(index)]++)
      ctx.fail("node " + std::to_string(index) + " appears twice in the node hierarchy");
    const tinygltf::Node& n = model.nodes[std::size_t(index)];
    const Placement place = compose(parent, local_placement(n, ctx));
    if (n.mesh >= 0) {
      append_mesh(model, n.mesh, place, g, ctx);
      any = true;
    }
    for (auto c = n.children.rbegin(); c != n.children.rend(); ++c) stack.emplace_back(*c, place);
  }
  return any;
}

}  // namespace

TriMesh read_gltf(std::string_view bytes, bool binary, ReadContext& ctx) {
  const tinygltf::Model model = load(bytes, binary, ctx);
  GltfMesh g;
  // The meshes where the scene's nodes place them; a file whose nodes place none (meshes
  // without nodes are valid glTF): every mesh as it is.
  if (!append_scene(model, g, ctx)) {
    g = GltfMesh();
    for (std::size_t m = 0; m < model.meshes.size(); ++m)
      append_mesh(model, int(m), kUnmoved, g, ctx);
  }
  if (g.mesh.triangles.empty()) ctx.fail("the file has no triangles");
  if (g.all_normals) g.mesh.normals = std::move(g.normals);
  if (g.all_colors) g.mesh.colors = std::move(g.colors);
  return std::move(g.mesh);
}

std::string read_gltf_params(std::string_view bytes, bool binary, const ReadContext& ctx) {
  const std::string_view json = binary ? split_glb(bytes, ctx).json : bytes;
  nlohmann::ordered_json doc;
  try {
    doc = nlohmann::ordered_json::parse(json.begin(), json.end());
  } catch (const nlohmann::json::exception& e) {
    ctx.fail(std::string("not a valid glTF file (") + e.what() + ")");
  }
  if (!doc.is_object() || !doc.contains("asset") || !doc["asset"].is_object())
    ctx.fail("not a valid glTF file (no asset)");
  const auto& asset = doc["asset"];
  if (!asset.contains("extras") || asset["extras"].is_null()) return "";
  return asset["extras"].dump(2);
}

}  // namespace qjulia::detail
