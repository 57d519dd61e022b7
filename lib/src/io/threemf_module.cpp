// libqjulia_3mf.so: 3MF through lib3mf 1.8 (its C interface), writer and reader (see
// threemf_module.h). The only file that includes lib3mf or libzip headers; it uses nothing of
// libqjulia. Before lib3mf sees a file, libzip (the zip library lib3mf reads it with)
// decompresses every entry once, counting, so a zip bomb is refused before it is parsed, and
// looks for the whitespace that overflows lib3mf's XML reader (WhitespaceScan below).
#include "io/threemf_module.h"

#include <Model/COM/NMR_DLLInterfaces.h>
#include <zip.h>

#include <algorithm>
#include <cstring>
#include <exception>
#include <memory>
#include <new>

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
  explicit Handle(PLib3MFBase* p) : p_(p) {}
  ~Handle() {
    if (p_) lib3mf_release(p_);
  }
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  PLib3MFBase* get() const { return p_; }
  PLib3MFBase* release() {
    PLib3MFBase* p = p_;
    p_ = nullptr;
    return p;
  }
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

/// Why a call failed, from an exception that reached it.
std::string failure(const std::exception_ptr& e) {
  try {
    std::rethrow_exception(e);
  } catch (const std::bad_alloc&) {
    return "out of memory";
  } catch (const std::exception& x) {
    return x.what();
  } catch (...) {
    return "unknown error";
  }
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

/// lib3mf's progress callback.
bool progress(int, ProgressIdentifier, void* user) {
  const ThreeMfWrite& in = *static_cast<const ThreeMfWrite*>(user);
  return in.keep_going(in.token);
}

/// A model with one mesh object, the build item, and the metadata. "" or what failed.
std::string build_model(const ThreeMfWrite& in, Handle& model) {
  Handle object, item;
  std::string why;  // the first failure; the steps after it are not taken
  auto ok = [&](LIB3MFRESULT r, PLib3MFBase* obj, const char* what) {
    if (r != LIB3MF_OK) why = std::string(what) + ": " + last_error(obj);
    return r == LIB3MF_OK;
  };
  // TriMesh's arrays have lib3mf's layout; setgeometry copies them.
  auto* vertices =
      reinterpret_cast<MODELMESHVERTEX*>(const_cast<std::array<float, 3>*>(in.positions));
  auto* triangles =
      reinterpret_cast<MODELMESHTRIANGLE*>(const_cast<std::array<std::uint32_t, 3>*>(in.triangles));
  ok(lib3mf_createmodel(model.out()), nullptr, "creating the model") &&
      ok(lib3mf_model_setunit(model.get(), unit_code(in.unit)), model.get(), "setting the unit") &&
      ok(lib3mf_model_addmeshobject(model.get(), object.out()), model.get(), "adding the mesh") &&
      ok(lib3mf_object_setnameutf8(object.get(), "qjulia"), object.get(), "naming the mesh") &&
      ok(lib3mf_object_settype(object.get(), MODELOBJECTTYPE_MODEL), object.get(),
         "setting the type") &&
      ok(lib3mf_meshobject_setgeometry(object.get(), vertices, DWORD(in.vertices), triangles,
                                       DWORD(in.faces)),
         object.get(), "setting the geometry") &&
      ok(lib3mf_model_addbuilditem(model.get(), object.get(), nullptr, item.out()), model.get(),
         "adding the build item") &&
      ok(lib3mf_object_setuuidutf8(object.get(), in.uuid[0].c_str()), object.get(),
         "naming the mesh by its UUID") &&
      ok(lib3mf_model_setbuilduuidutf8(model.get(), in.uuid[1].c_str()), model.get(),
         "naming the build by its UUID") &&
      ok(lib3mf_builditem_setuuidutf8(item.get(), in.uuid[2].c_str()), item.get(),
         "naming the build item by its UUID") &&
      ok(lib3mf_model_addmetadatautf8(model.get(), "Application", in.generator.c_str()),
         model.get(), "adding metadata") &&
      (in.params.empty() ||
       ok(lib3mf_model_addmetadatautf8(model.get(), kParamsKey, in.params.c_str()), model.get(),
          "adding the parameters as metadata"));
  return why;
}

/// lib3mf writes its zip stream here, in memory: lib3mf 1.8 terminates the process when a
/// write to a file fails (it throws from a destructor), so only qjulia's AtomicFile writes.
struct MemoryStream {
  std::string& bytes;
  std::size_t position = 0;
};

unsigned write_callback(unsigned char* data, unsigned size, void* user) {
  auto& s = *static_cast<MemoryStream*>(user);
  try {  // nothing may be thrown through lib3mf
    if (s.position + size > s.bytes.size()) s.bytes.resize(s.position + size);
  } catch (...) {
    return 1;
  }
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

std::string write(const ThreeMfWrite& in, std::string& bytes) {
  try {
    Handle model, writer;
    std::string why = build_model(in, model);
    if (!why.empty()) return why;
    if (lib3mf_model_querywriter(model.get(), "3mf", writer.out()) != LIB3MF_OK)
      return "creating the writer: " + last_error(model.get());
    if (in.keep_going)
      lib3mf_writer_setprogresscallback(writer.get(), progress, const_cast<ThreeMfWrite*>(&in));
    bytes.clear();
    MemoryStream stream{bytes};
    if (lib3mf_writer_writetocallback(writer.get(), reinterpret_cast<void*>(write_callback),
                                      reinterpret_cast<void*>(seek_callback), &stream) != LIB3MF_OK)
      return "writing: " + last_error(writer.get());
    return "";
  } catch (...) {
    return "writing: " + failure(std::current_exception());
  }
}

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

std::string scan(std::string_view bytes, std::size_t& total) {
  try {
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
      return "not a valid 3MF file (not a zip archive: " + why + ")";
    }
    zip_error_fini(&error);
    total = 0;
    std::vector<char> buffer(std::size_t(1) << 16);
    const zip_int64_t entries = zip_get_num_entries(archive.get(), 0);
    for (zip_int64_t i = 0; i < entries; ++i) {
      zip_file_t* f = zip_fopen_index(archive.get(), zip_uint64_t(i), 0);
      if (!f) continue;  // lib3mf will report what it cannot open
      WhitespaceScan whitespace;
      zip_int64_t n;
      while ((n = zip_fread(f, buffer.data(), buffer.size())) > 0) {
        total += std::size_t(n);
        if (total > cap) {
          zip_fclose(f);
          return "refused: the archive decompresses to more than " + std::to_string(cap) +
                 " bytes, " + std::to_string(kMaxRatio) +
                 " times its size (a zip bomb or not a mesh)";
        }
        const std::string why = whitespace.feed(buffer.data(), std::size_t(n));
        if (!why.empty()) {
          zip_fclose(f);
          const char* name = zip_get_name(archive.get(), zip_uint64_t(i), 0);
          return "refused: the part '" + std::string(name ? name : "?") + "' " + why +
                 " (lib3mf, which reads 3MF files, overflows its memory on such XML)";
        }
      }
      zip_fclose(f);
    }
    return "";
  } catch (...) {
    return failure(std::current_exception());
  }
}

void* open_model(std::string_view bytes, std::string& error) {
  try {
    Handle model, reader;
    if (lib3mf_createmodel(model.out()) != LIB3MF_OK) {
      error = "lib3mf cannot create a model";
      return nullptr;
    }
    if (lib3mf_model_queryreader(model.get(), "3mf", reader.out()) != LIB3MF_OK) {
      error = "lib3mf cannot create a reader: " + last_error(model.get());
      return nullptr;
    }
    BYTE* data = reinterpret_cast<BYTE*>(const_cast<char*>(bytes.data()));  // only read
    if (lib3mf_reader_readfrombuffer(reader.get(), data, bytes.size()) != LIB3MF_OK) {
      error = "not a valid 3MF file (" + last_error(reader.get()) + ")";
      return nullptr;
    }
    return model.release();
  } catch (...) {
    error = failure(std::current_exception());
    return nullptr;
  }
}

void close_model(void* model) {
  if (model) lib3mf_release(static_cast<PLib3MFBase*>(model));
}

/// Calls f(object) for each mesh object of the model; "" or what failed.
template <class F>
std::string each_object(void* model, F&& f) {
  Handle it;
  if (lib3mf_model_getmeshobjects(static_cast<PLib3MFBase*>(model), it.out()) != LIB3MF_OK)
    return last_error(static_cast<PLib3MFBase*>(model));
  BOOL has_next = false;
  while (lib3mf_resourceiterator_movenext(it.get(), &has_next) == LIB3MF_OK && has_next) {
    Handle object;
    if (lib3mf_resourceiterator_getcurrent(it.get(), object.out()) != LIB3MF_OK)
      return last_error(it.get());
    const std::string why = f(object.get());
    if (!why.empty()) return why;
  }
  return "";
}

std::string sizes(void* model, std::vector<std::array<std::size_t, 2>>& out) {
  try {
    out.clear();
    return each_object(model, [&](PLib3MFBase* object) -> std::string {
      DWORD nv = 0, nf = 0;
      if (lib3mf_meshobject_getvertexcount(object, &nv) != LIB3MF_OK ||
          lib3mf_meshobject_gettrianglecount(object, &nf) != LIB3MF_OK)
        return last_error(object);
      out.push_back({nv, nf});
      return "";
    });
  } catch (...) {
    return failure(std::current_exception());
  }
}

std::string mesh(void* model, std::array<float, 3>* positions,
                 std::array<std::uint32_t, 3>* triangles) {
  try {
    std::size_t base_v = 0, base_f = 0;
    return each_object(model, [&](PLib3MFBase* object) -> std::string {
      DWORD nv = 0, nf = 0, got = 0;
      if (lib3mf_meshobject_getvertexcount(object, &nv) != LIB3MF_OK ||
          lib3mf_meshobject_gettrianglecount(object, &nf) != LIB3MF_OK)
        return last_error(object);
      if (nv && lib3mf_meshobject_getvertices(
                    object, reinterpret_cast<MODELMESHVERTEX*>(positions + base_v), nv, &got) !=
                    LIB3MF_OK)
        return last_error(object);
      if (nf && lib3mf_meshobject_gettriangleindices(
                    object, reinterpret_cast<MODELMESHTRIANGLE*>(triangles + base_f), nf, &got) !=
                    LIB3MF_OK)
        return last_error(object);
      for (std::size_t f = base_f; f < base_f + nf; ++f)
        for (auto& i : triangles[f]) {
          if (i >= nv) return "a triangle index is out of range";
          i += std::uint32_t(base_v);
        }
      base_v += nv;
      base_f += nf;
      return "";
    });
  } catch (...) {
    return failure(std::current_exception());
  }
}

std::string description(void* model_handle, std::string& value) {
  try {
    auto* model = static_cast<PLib3MFBase*>(model_handle);
    value.clear();
    DWORD count = 0;
    lib3mf_model_getmetadatacount(model, &count);
    for (DWORD i = 0; i < count; ++i) {
      ULONG need = 0;
      lib3mf_model_getmetadatakeyutf8(model, i, nullptr, 0, &need);
      std::string key(need + 1, '\0');
      lib3mf_model_getmetadatakeyutf8(model, i, key.data(), ULONG(key.size()), &need);
      key.resize(std::strlen(key.c_str()));
      if (key != kParamsKey) continue;
      lib3mf_model_getmetadatavalueutf8(model, i, nullptr, 0, &need);
      value.assign(need + 1, '\0');
      lib3mf_model_getmetadatavalueutf8(model, i, value.data(), ULONG(value.size()), &need);
      value.resize(std::strlen(value.c_str()));
      return "";
    }
    return "";
  } catch (...) {
    return failure(std::current_exception());
  }
}

}  // namespace
}  // namespace qjulia::detail

extern "C" __attribute__((visibility("default"))) const qjulia::detail::ThreeMfApi*
qjulia_3mf_api() {
  namespace d = qjulia::detail;
  static const d::ThreeMfApi api{d::kThreeMfApiVersion, &d::write, &d::scan, &d::open_model,
                                 &d::close_model,       &d::sizes, &d::mesh, &d::description};
  return &api;
}
