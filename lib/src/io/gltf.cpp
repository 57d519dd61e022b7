// glTF 2.0 (.glb and .gltf + .bin) through tinygltf. The only file that includes tiny_gltf.h.
#include <tiny_gltf.h>

#include <cstring>
#include <nlohmann/json.hpp>
#include <sstream>

#include "qjulia/base/atomic_file.h"
#include "io/formats.h"
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

}  // namespace

void write_gltf(const std::string& path, const ExportData& data, bool binary) {
  const TriMesh& mesh = data.mesh;
  const std::size_t nv = mesh.positions.size();
  const std::size_t nf = mesh.triangles.size();
  const bool colored = !data.colors.empty();

  std::vector<Span> chunks = {{mesh.triangles.data(), nf * 12},
                              {mesh.positions.data(), nv * 12},
                              {data.normals.data(), nv * 12}};
  if (colored) chunks.push_back({data.colors.data(), nv * 12});

  tinygltf::Model model;
  model.asset.version = "2.0";
  model.asset.generator = data.generator;

  tinygltf::Buffer buffer;  // data is written by us below, straight from the mesh arrays
  model.buffers.push_back(buffer);
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
  const std::size_t total = offset;
  if (total + 4096 > UINT32_MAX) {
    throw InvalidInput(path + ": the mesh is too big for glTF (buffer over 4 GB)");
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
  const int indices =
      add_accessor(0, TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT, TINYGLTF_TYPE_SCALAR, nf * 3);
  const int position = add_accessor(1, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, nv);
  {
    // The validator requires min/max to equal the data's exactly (as float32).
    std::array<float, 3> lo = mesh.positions[0], hi = mesh.positions[0];
    for (const auto& p : mesh.positions)
      for (int i = 0; i < 3; ++i) {
        lo[i] = std::min(lo[i], p[i]);
        hi[i] = std::max(hi[i], p[i]);
      }
    model.accessors[position].minValues = {lo[0], lo[1], lo[2]};
    model.accessors[position].maxValues = {hi[0], hi[1], hi[2]};
  }
  const int normal = add_accessor(2, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, nv);
  int color = -1;
  if (colored) color = add_accessor(3, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, nv);

  // White base colour times COLOR_0: Blender's importer and web viewers then show the colours.
  tinygltf::Material material;
  material.name = "qjulia";
  material.pbrMetallicRoughness.baseColorFactor = {1.0, 1.0, 1.0, 1.0};
  material.pbrMetallicRoughness.metallicFactor = 0.0;
  material.pbrMetallicRoughness.roughnessFactor = 0.6;
  material.doubleSided = false;
  model.materials.push_back(material);

  tinygltf::Primitive primitive;
  primitive.mode = TINYGLTF_MODE_TRIANGLES;
  primitive.indices = indices;
  primitive.material = 0;
  primitive.attributes["POSITION"] = position;
  primitive.attributes["NORMAL"] = normal;
  if (colored) primitive.attributes["COLOR_0"] = color;
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
  const std::string bin_path = bin_path_for(path);
  if (!binary) buf_json["uri"] = uri_encode(file_name(bin_path));
  doc["buffers"] = nlohmann::ordered_json::array({buf_json});
  if (!data.params_json.empty()) {
    doc["asset"]["extras"] = nlohmann::ordered_json::parse(data.params_json);
  }

  if (binary) {
    std::string json = doc.dump();
    while (json.size() % 4 != 0) json += ' ';
    const uint32_t header[3] = {kGlbMagic, 2, uint32_t(12 + 8 + json.size() + 8 + total)};
    const uint32_t json_head[2] = {uint32_t(json.size()), kChunkJson};
    const uint32_t bin_head[2] = {uint32_t(total), kChunkBin};
    AtomicFile out(path);
    out.write(header, sizeof header);
    out.write(json_head, sizeof json_head);
    out.write(json);
    out.write(bin_head, sizeof bin_head);
    for (const Span& c : chunks) out.write(c.data, c.size);
    out.commit();
  } else {
    AtomicFile bin(bin_path);
    for (const Span& c : chunks) bin.write(c.data, c.size);
    AtomicFile out(path);
    out.write(doc.dump(2) + "\n");
    bin.commit();
    try {
      out.commit();
    } catch (...) {
      std::remove(bin_path.c_str());
      throw;
    }
  }
}

namespace {

/// Reads accessor `index` as #count vectors of `n` floats (float, or normalized ubyte/ushort).
std::vector<std::array<float, 3>> read_vec3(const std::string& path, const tinygltf::Model& m,
                                            int index, const char* what, bool allow_vec4) {
  if (index < 0 || std::size_t(index) >= m.accessors.size())
    fail(path, std::string(what) + " accessor missing");
  const tinygltf::Accessor& a = m.accessors[index];
  if (a.sparse.isSparse) fail(path, std::string(what) + ": sparse accessors are not supported");
  const int comps = a.type == TINYGLTF_TYPE_VEC3 ? 3 : a.type == TINYGLTF_TYPE_VEC4 ? 4 : 0;
  if (comps == 0 || (comps == 4 && !allow_vec4)) {
    fail(path, std::string(what) + " accessor has type " + std::to_string(a.type) +
                   " (expected VEC3" + (allow_vec4 ? " or VEC4)" : ")"));
  }
  int csize = 0;
  switch (a.componentType) {
    case TINYGLTF_COMPONENT_TYPE_FLOAT:
      csize = 4;
      break;
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
      csize = 1;
      break;
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT:
      csize = 2;
      break;
    default:
      fail(path, std::string(what) + " accessor has an unsupported component type");
  }
  if (csize != 4 && !a.normalized)
    fail(path, std::string(what) + " integer accessor must be normalized");
  if (a.count == 0) return {};
  if (a.bufferView < 0 || std::size_t(a.bufferView) >= m.bufferViews.size())
    fail(path, std::string(what) + " accessor has no buffer view");
  const tinygltf::BufferView& v = m.bufferViews[a.bufferView];
  if (v.buffer < 0 || std::size_t(v.buffer) >= m.buffers.size())
    fail(path, std::string(what) + " buffer view has no buffer");
  const auto& buf = m.buffers[v.buffer].data;
  const std::size_t elem = std::size_t(csize) * comps;
  const std::size_t stride = v.byteStride ? v.byteStride : elem;
  const std::size_t begin = v.byteOffset + a.byteOffset;
  if (v.byteOffset > buf.size() || v.byteLength > buf.size() ||
      v.byteOffset + v.byteLength > buf.size() || a.count > v.byteLength || stride > 256 ||
      a.byteOffset > v.byteLength || a.byteOffset + (a.count - 1) * stride + elem > v.byteLength) {
    fail(path,
         std::string(what) + " accessor reaches past the end of its buffer (truncated file?)");
  }
  std::vector<std::array<float, 3>> out(a.count);  // after the bounds check: count is trusted
  const unsigned char* p = buf.data() + begin;
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

std::vector<uint32_t> read_indices(const std::string& path, const tinygltf::Model& m, int index) {
  const tinygltf::Accessor& a = m.accessors.at(index);
  if (a.type != TINYGLTF_TYPE_SCALAR || a.sparse.isSparse)
    fail(path, "the index accessor is not a plain SCALAR");
  int csize = 0;
  switch (a.componentType) {
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
      csize = 1;
      break;
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT:
      csize = 2;
      break;
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
      csize = 4;
      break;
    default:
      fail(path, "the index accessor has an unsupported component type");
  }
  if (a.count == 0) return {};
  if (a.bufferView < 0 || std::size_t(a.bufferView) >= m.bufferViews.size())
    fail(path, "the index accessor has no buffer view");
  const tinygltf::BufferView& v = m.bufferViews[a.bufferView];
  if (v.buffer < 0 || std::size_t(v.buffer) >= m.buffers.size())
    fail(path, "the index buffer view has no buffer");
  const auto& buf = m.buffers[v.buffer].data;
  const std::size_t stride = v.byteStride ? v.byteStride : csize;
  if (v.byteOffset > buf.size() || v.byteLength > buf.size() ||
      v.byteOffset + v.byteLength > buf.size() || a.count > v.byteLength || stride > 256 ||
      a.byteOffset > v.byteLength || a.byteOffset + (a.count - 1) * stride + csize > v.byteLength) {
    fail(path, "the index accessor reaches past the end of its buffer (truncated file?)");
  }
  std::vector<uint32_t> out(a.count);
  const unsigned char* p = buf.data() + v.byteOffset + a.byteOffset;
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

tinygltf::Model load(const std::string& path, bool binary) {
  // Checked here so a missing file says so (tinygltf's message is less clear).
  std::string bytes = read_file(path);
  tinygltf::Model model;
  tinygltf::TinyGLTF loader;
  std::string err, warn;
  const auto slash = path.find_last_of('/');
  const std::string base_dir = slash == std::string::npos ? "." : path.substr(0, slash);
  bool ok;
  if (binary) {
    ok = loader.LoadBinaryFromMemory(&model, &err, &warn,
                                     reinterpret_cast<const unsigned char*>(bytes.data()),
                                     unsigned(bytes.size()), base_dir);
  } else {
    ok = loader.LoadASCIIFromString(&model, &err, &warn, bytes.data(), unsigned(bytes.size()),
                                    base_dir);
  }
  if (!ok) {
    while (!err.empty() && (err.back() == '\n' || err.back() == ' ')) err.pop_back();
    for (auto& c : err)
      if (c == '\n') c = ' ';
    fail(path,
         "not a valid glTF file (" + (err.empty() ? std::string("tinygltf failed") : err) + ")");
  }
  return model;
}

}  // namespace

TriMesh read_gltf(const std::string& path, bool binary) {
  const tinygltf::Model model = load(path, binary);
  TriMesh mesh;
  bool all_normals = true, all_colors = true;
  std::vector<std::array<float, 3>> normals, colors;
  for (const auto& gm : model.meshes) {
    for (const auto& prim : gm.primitives) {
      if (prim.mode != -1 && prim.mode != TINYGLTF_MODE_TRIANGLES) continue;
      const auto pos_it = prim.attributes.find("POSITION");
      if (pos_it == prim.attributes.end()) fail(path, "a primitive has no POSITION");
      const auto pos = read_vec3(path, model, pos_it->second, "POSITION", false);
      const uint32_t base = uint32_t(mesh.positions.size());
      std::vector<uint32_t> idx;
      if (prim.indices >= 0) {
        if (std::size_t(prim.indices) >= model.accessors.size())
          fail(path, "a primitive's index accessor is missing");
        idx = read_indices(path, model, prim.indices);
      } else {
        idx.resize(pos.size());
        for (std::size_t i = 0; i < idx.size(); ++i) idx[i] = uint32_t(i);
      }
      if (idx.size() % 3 != 0)
        fail(path, "a triangle primitive's index count is not a multiple of 3");
      for (std::size_t i = 0; i < idx.size(); i += 3) {
        for (int k = 0; k < 3; ++k)
          if (idx[i + k] >= pos.size()) {
            fail(path, "index " + std::to_string(idx[i + k]) + " is out of range (" +
                           std::to_string(pos.size()) + " vertices)");
          }
        mesh.triangles.push_back({base + idx[i], base + idx[i + 1], base + idx[i + 2]});
      }
      mesh.positions.insert(mesh.positions.end(), pos.begin(), pos.end());
      const auto n_it = prim.attributes.find("NORMAL");
      if (all_normals && n_it != prim.attributes.end()) {
        const auto n = read_vec3(path, model, n_it->second, "NORMAL", false);
        if (n.size() != pos.size()) fail(path, "NORMAL and POSITION counts differ");
        normals.insert(normals.end(), n.begin(), n.end());
      } else {
        all_normals = false;
      }
      const auto c_it = prim.attributes.find("COLOR_0");
      if (all_colors && c_it != prim.attributes.end()) {
        const auto c = read_vec3(path, model, c_it->second, "COLOR_0", true);
        if (c.size() != pos.size()) fail(path, "COLOR_0 and POSITION counts differ");
        colors.insert(colors.end(), c.begin(), c.end());
      } else {
        all_colors = false;
      }
    }
  }
  if (mesh.triangles.empty()) fail(path, "the file has no triangles");
  if (all_normals) mesh.normals = std::move(normals);
  if (all_colors) mesh.colors = std::move(colors);
  return mesh;
}

std::string read_gltf_params(const std::string& path, bool binary) {
  const std::string bytes = read_file(path);
  std::string json;
  if (binary) {
    uint32_t head[5];
    if (bytes.size() < sizeof head) fail(path, "not a GLB file (too short)");
    std::memcpy(head, bytes.data(), sizeof head);
    if (head[0] != kGlbMagic || head[4] != kChunkJson || 20 + std::size_t(head[3]) > bytes.size()) {
      fail(path, "not a GLB file (bad header)");
    }
    json = bytes.substr(20, head[3]);
  } else {
    json = bytes;
  }
  nlohmann::ordered_json doc;
  try {
    doc = nlohmann::ordered_json::parse(json);
  } catch (const nlohmann::json::exception& e) {
    fail(path, std::string("not a valid glTF file (") + e.what() + ")");
  }
  if (!doc.is_object() || !doc.contains("asset") || !doc["asset"].is_object())
    fail(path, "not a valid glTF file (no asset)");
  const auto& asset = doc["asset"];
  if (!asset.contains("extras") || asset["extras"].is_null()) return "";
  return asset["extras"].dump(2);
}

}  // namespace qjulia::detail
