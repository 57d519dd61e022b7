// 3MF through lib3mf 1.8 (its C interface), writer and reader. The only file that includes
// lib3mf headers. Before lib3mf sees a file, libzip (the zip library lib3mf reads it with)
// decompresses every entry once, counting, so a zip bomb is refused before it is parsed, and
// looking for the whitespace that overflows lib3mf's XML reader (ArchiveScan below).
#include <Model/COM/NMR_DLLInterfaces.h>
#include <zip.h>

#include <cstdint>
#include <cstring>
#include <memory>

#include "base/hash.h"
#include "io/formats.h"
#include "qjulia/base/atomic_file.h"
#include "qjulia/base/error.h"

namespace qjulia::detail {
namespace {

using namespace NMR;

static_assert(sizeof(MODELMESHVERTEX) == 12 && sizeof(MODELMESHTRIANGLE) == 12,
              "lib3mf's vertex and triangle have the layout of TriMesh's arrays");

/// A 3MF may decompress to at most this many times its size (and at least kMinDecompressed):
/// the XML of a mesh compresses 4 to 10 times, a zip bomb a thousand times.
constexpr std::size_t kMaxRatio = 100;
constexpr std::size_t kMinDecompressed = std::size_t(1) << 20;

/// lib3mf 1.8's XML reader (NMR_XmlReader_Native.cpp, parseAttributeName) records one entity
/// and one or two zero-inserts for every whitespace character between an attribute's name and
/// its '=' (or wherever that whitespace ends), in arrays of its 64 KiB read buffer's size that
/// it never checks: 32768 spaces after a prefixed attribute name, or twelve attributes of one
/// tag with 4000 spaces each before '=', overflow the heap (found by mesh_3mf_fuzz; XML allows
/// such whitespace, no writer produces it, and lib3mf refuses two or more of those spaces when
/// it survives them). Every part is therefore refused when it holds a whitespace run longer
/// than kMaxWhitespaceRun, or more than kMaxWhitespaceBeforeEquals whitespace characters in
/// runs directly before an '=': at most 2 x 8192 zero-inserts come from whitespace in one
/// buffer, the other entities of a buffer take fewer than one per two characters.
constexpr std::size_t kMaxWhitespaceRun = 4096;
constexpr std::size_t kMaxWhitespaceBeforeEquals = 4096;

/// Owns one lib3mf object and releases it.
class Handle {
 public:
  Handle() = default;
  ~Handle() {
    if (p_) lib3mf_release(p_);
  }
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  PLib3MFBase* get() const { return p_; }
  PLib3MFBase** out() {
    if (p_) lib3mf_release(p_);
    p_ = nullptr;
    return &p_;
  }

 private:
  PLib3MFBase* p_ = nullptr;
};

std::string last_error(PLib3MFBase* obj) {
  DWORD code = 0;
  LPCSTR msg = nullptr;
  if (obj && lib3mf_getlasterror(obj, &code, &msg) == LIB3MF_OK && msg && *msg) {
    return std::string(msg) + " (lib3mf error " + std::to_string(code) + ")";
  }
  return "lib3mf error";
}

// 3MF 1.x readers (lib3mf among them) reject namespaced metadata whose namespace the writer
// did not declare, and lib3mf 1.8 cannot declare one: the parameters go in the well-known
// "Description".
const char* kParamsKey = "Description";

DWORD unit_code(const std::string& unit) {
  if (unit == "um") return MODELUNIT_MICROMETER;
  if (unit == "cm") return MODELUNIT_CENTIMETER;
  if (unit == "in") return MODELUNIT_INCH;
  if (unit == "ft") return MODELUNIT_FOOT;
  if (unit == "m") return MODELUNIT_METER;
  return MODELUNIT_MILLIMETER;  // "mm" and model units alike: 3MF's default
}

/// lib3mf's progress callback: false stops the writer when the token is set.
bool keep_going(int, ProgressIdentifier, void* token) {
  return !static_cast<const CancelToken*>(token)->requested();
}

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

/// A model with one mesh object, the build item, and the metadata.
void build_model(const std::string& path, const ExportData& data, Handle& model) {
  const TriMesh& mesh = data.mesh;
  auto check = [&](LIB3MFRESULT r, PLib3MFBase* obj, const char* what) {
    if (r != LIB3MF_OK) throw std::runtime_error(path + ": " + what + ": " + last_error(obj));
  };
  Handle object, item;
  check(lib3mf_createmodel(model.out()), nullptr, "creating the model");
  check(lib3mf_model_setunit(model.get(), unit_code(data.unit)), model.get(), "setting the unit");
  check(lib3mf_model_addmeshobject(model.get(), object.out()), model.get(), "adding the mesh");
  check(lib3mf_object_setnameutf8(object.get(), "qjulia"), object.get(), "naming the mesh");
  check(lib3mf_object_settype(object.get(), MODELOBJECTTYPE_MODEL), object.get(),
        "setting the type");
  // TriMesh's arrays have lib3mf's layout; setgeometry copies them.
  check(lib3mf_meshobject_setgeometry(
            object.get(),
            reinterpret_cast<MODELMESHVERTEX*>(
                const_cast<std::array<float, 3>*>(mesh.positions.data())),
            DWORD(mesh.positions.size()),
            reinterpret_cast<MODELMESHTRIANGLE*>(
                const_cast<std::array<uint32_t, 3>*>(mesh.triangles.data())),
            DWORD(mesh.triangles.size())),
        object.get(), "setting the geometry");
  check(lib3mf_model_addbuilditem(model.get(), object.get(), nullptr, item.out()), model.get(),
        "adding the build item");
  const std::uint64_t h = content_hash(data);
  check(lib3mf_object_setuuidutf8(object.get(), content_uuid(h, 1).c_str()), object.get(),
        "naming the mesh by its UUID");
  check(lib3mf_model_setbuilduuidutf8(model.get(), content_uuid(h, 2).c_str()), model.get(),
        "naming the build by its UUID");
  check(lib3mf_builditem_setuuidutf8(item.get(), content_uuid(h, 3).c_str()), item.get(),
        "naming the build item by its UUID");
  check(lib3mf_model_addmetadatautf8(model.get(), "Application", data.generator.c_str()),
        model.get(), "adding metadata");
  if (!data.params_json.empty()) {
    check(lib3mf_model_addmetadatautf8(model.get(), kParamsKey, data.params_json.c_str()),
          model.get(), "adding the parameters as metadata");
  }
}

/// lib3mf writes its zip stream here, in memory: lib3mf 1.8 terminates the process when a
/// write to a file fails (it throws from a destructor), so only qjulia's AtomicFile writes.
struct MemoryStream {
  std::string bytes;
  std::size_t position = 0;
};

unsigned write_callback(unsigned char* data, unsigned size, void* user) {
  auto& s = *static_cast<MemoryStream*>(user);
  if (s.position + size > s.bytes.size()) s.bytes.resize(s.position + size);
  std::memcpy(s.bytes.data() + s.position, data, size);
  s.position += size;
  return 0;  // LIB3MF_OK
}

unsigned seek_callback(unsigned long long position, void* user) {
  auto& s = *static_cast<MemoryStream*>(user);
  if (position > s.bytes.size()) return 1;
  s.position = std::size_t(position);
  return 0;
}

}  // namespace

void write_3mf(const std::string& path, const ExportData& data) {
  Handle model, writer;
  build_model(path, data, model);
  if (lib3mf_model_querywriter(model.get(), "3mf", writer.out()) != LIB3MF_OK)
    throw std::runtime_error(path + ": creating the writer: " + last_error(model.get()));
  if (data.cancel) {
    lib3mf_writer_setprogresscallback(writer.get(), keep_going,
                                      const_cast<CancelToken*>(data.cancel));
  }
  AtomicFile file(path, data.cancel);  // checks the path before the work
  MemoryStream stream;
  if (lib3mf_writer_writetocallback(writer.get(), reinterpret_cast<void*>(write_callback),
                                    reinterpret_cast<void*>(seek_callback), &stream) != LIB3MF_OK) {
    throw_if_cancelled(data.cancel);
    throw std::runtime_error(path + ": writing: " + last_error(writer.get()));
  }
  file.write(stream.bytes);
  file.commit();
}

namespace {

/// Frees a libzip archive.
struct ZipCloser {
  void operator()(zip_t* z) const { zip_discard(z); }
};

/// The whitespace of one decompressed part, fed in blocks (kMaxWhitespaceRun above).
class WhitespaceScan {
 public:
  /// Why the part is refused, or "" while it is not.
  std::string feed(const char* p, std::size_t n) {
    for (std::size_t i = 0; i < n; ++i) {
      const char c = p[i];
      if (c == ' ' || c == '\t' || c == '\n' || c == '\r') {
        if (++run_ > kMaxWhitespaceRun) {
          return "holds more than " + std::to_string(kMaxWhitespaceRun) +
                 " whitespace characters in a row";
        }
        continue;
      }
      if (c == '=' && (before_equals_ += run_) > kMaxWhitespaceBeforeEquals) {
        return "holds more than " + std::to_string(kMaxWhitespaceBeforeEquals) +
               " whitespace characters before '=' signs";
      }
      run_ = 0;
    }
    return "";
  }

 private:
  std::size_t run_ = 0;
  std::size_t before_equals_ = 0;
};

/// Decompresses every entry of the zip in `bytes` with libzip, discarding the output, and
/// refuses the file when the total exceeds kMaxRatio times its size (zip headers may
/// understate sizes, so they are counted, not believed) or when a part holds the whitespace
/// that lib3mf's XML reader overflows on (WhitespaceScan). Returns the total.
std::size_t check_decompressed_size(std::string_view bytes, ReadContext& ctx) {
  const std::size_t cap = std::max(kMaxRatio * bytes.size(), kMinDecompressed);
  zip_error_t error;
  zip_error_init(&error);
  zip_source_t* source = zip_source_buffer_create(bytes.data(), bytes.size(), 0, &error);
  std::unique_ptr<zip_t, ZipCloser> archive(
      source ? zip_open_from_source(source, ZIP_RDONLY, &error) : nullptr);
  if (!archive) {
    if (source) zip_source_free(source);
    const std::string why = zip_error_strerror(&error);
    zip_error_fini(&error);
    ctx.fail("not a valid 3MF file (not a zip archive: " + why + ")");
  }
  zip_error_fini(&error);
  std::size_t total = 0;
  std::vector<char> buffer(std::size_t(1) << 16);
  const zip_int64_t entries = zip_get_num_entries(archive.get(), 0);
  for (zip_int64_t i = 0; i < entries; ++i) {
    zip_file_t* f = zip_fopen_index(archive.get(), zip_uint64_t(i), 0);
    if (!f) continue;  // lib3mf will report what it cannot open
    WhitespaceScan scan;
    zip_int64_t n;
    while ((n = zip_fread(f, buffer.data(), buffer.size())) > 0) {
      total += std::size_t(n);
      if (total > cap) {
        zip_fclose(f);
        ctx.fail("refused: the archive decompresses to more than " + std::to_string(cap) +
                 " bytes, " + std::to_string(kMaxRatio) +
                 " times its size (a zip bomb or not a mesh)");
      }
      const std::string why = scan.feed(buffer.data(), std::size_t(n));
      if (!why.empty()) {
        zip_fclose(f);
        const char* name = zip_get_name(archive.get(), zip_uint64_t(i), 0);
        ctx.fail("refused: the part '" + std::string(name ? name : "?") + "' " + why +
                 " (lib3mf, which reads 3MF files, overflows its memory on such XML)");
      }
    }
    zip_fclose(f);
  }
  return total;
}

/// Parses `bytes` into `model` with lib3mf.
void load(std::string_view bytes, Handle& model, ReadContext& ctx) {
  const std::size_t decompressed = check_decompressed_size(bytes, ctx);
  // lib3mf parses the XML as it streams; its model takes about as much as the XML.
  ctx.charge(decompressed, "the 3MF model");
  Handle reader;
  if (lib3mf_createmodel(model.out()) != LIB3MF_OK) ctx.fail("lib3mf cannot create a model");
  if (lib3mf_model_queryreader(model.get(), "3mf", reader.out()) != LIB3MF_OK)
    ctx.fail("lib3mf cannot create a reader: " + last_error(model.get()));
  BYTE* data = reinterpret_cast<BYTE*>(const_cast<char*>(bytes.data()));  // only read
  if (lib3mf_reader_readfrombuffer(reader.get(), data, bytes.size()) != LIB3MF_OK)
    ctx.fail("not a valid 3MF file (" + last_error(reader.get()) + ")");
}

/// Appends the vertices and triangles of one mesh object to `mesh`.
void append_object(PLib3MFBase* object, TriMesh& mesh, ReadContext& ctx) {
  DWORD nv = 0, nf = 0;
  if (lib3mf_meshobject_getvertexcount(object, &nv) != LIB3MF_OK ||
      lib3mf_meshobject_gettrianglecount(object, &nf) != LIB3MF_OK) {
    ctx.fail(last_error(object));
  }
  const std::size_t base_v = mesh.positions.size(), base_f = mesh.triangles.size();
  reserve_charged(mesh.positions, base_v + nv, ctx, "vertices");
  reserve_charged(mesh.triangles, base_f + nf, ctx, "triangles");
  mesh.positions.resize(base_v + nv);
  mesh.triangles.resize(base_f + nf);
  DWORD got = 0;
  if (nv && lib3mf_meshobject_getvertices(
                object, reinterpret_cast<MODELMESHVERTEX*>(mesh.positions.data() + base_v), nv,
                &got) != LIB3MF_OK) {
    ctx.fail(last_error(object));
  }
  if (nf && lib3mf_meshobject_gettriangleindices(
                object, reinterpret_cast<MODELMESHTRIANGLE*>(mesh.triangles.data() + base_f), nf,
                &got) != LIB3MF_OK) {
    ctx.fail(last_error(object));
  }
  for (std::size_t f = base_f; f < mesh.triangles.size(); ++f)
    for (auto& i : mesh.triangles[f]) {
      if (i >= nv) ctx.fail("a triangle index is out of range");
      i += uint32_t(base_v);
    }
}

}  // namespace

TriMesh read_3mf(std::string_view bytes, ReadContext& ctx) {
  Handle model, it;
  load(bytes, model, ctx);
  if (lib3mf_model_getmeshobjects(model.get(), it.out()) != LIB3MF_OK)
    ctx.fail(last_error(model.get()));
  TriMesh mesh;
  BOOL has_next = false;
  while (lib3mf_resourceiterator_movenext(it.get(), &has_next) == LIB3MF_OK && has_next) {
    Handle object;
    if (lib3mf_resourceiterator_getcurrent(it.get(), object.out()) != LIB3MF_OK)
      ctx.fail(last_error(it.get()));
    append_object(object.get(), mesh, ctx);
  }
  if (mesh.triangles.empty()) ctx.fail("the 3MF file has no triangles");
  return mesh;
}

std::string read_3mf_params(std::string_view bytes, ReadContext& ctx) {
  Handle model;
  load(bytes, model, ctx);
  DWORD count = 0;
  lib3mf_model_getmetadatacount(model.get(), &count);
  for (DWORD i = 0; i < count; ++i) {
    ULONG need = 0;
    lib3mf_model_getmetadatakeyutf8(model.get(), i, nullptr, 0, &need);
    std::string key(need + 1, '\0');
    lib3mf_model_getmetadatakeyutf8(model.get(), i, key.data(), ULONG(key.size()), &need);
    key.resize(std::strlen(key.c_str()));
    if (key != kParamsKey) continue;
    lib3mf_model_getmetadatavalueutf8(model.get(), i, nullptr, 0, &need);
    std::string value(need + 1, '\0');
    lib3mf_model_getmetadatavalueutf8(model.get(), i, value.data(), ULONG(value.size()), &need);
    value.resize(std::strlen(value.c_str()));
    return value;
  }
  return "";
}

}  // namespace qjulia::detail
