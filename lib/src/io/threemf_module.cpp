// libqjulia_3mf.so: 3MF through lib3mf 1.8 (its C interface), writer and reader (see
// threemf_module.h). The only file that includes lib3mf or libzip headers; it uses nothing of
// libqjulia. Before lib3mf sees a file, libzip (the zip library lib3mf reads it with)
// decompresses every entry once, counting, so a zip bomb is refused before it is parsed, and
// looks for the whitespace that overflows lib3mf's XML reader (WhitespaceScan below).
#include "io/threemf_module.h"

#include <Model/COM/NMR_DLLInterfaces.h>
#include <zip.h>

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <map>
#include <memory>
#include <new>

#include "base/placement.h"

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

/// The most meshes a model may place (components nest: a few objects can place exponentially
/// many).
constexpr std::size_t kMostPlaced = 1000000;

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

/// The components of a model part: which objects each object places, fed in blocks. lib3mf
/// walks every path down nested components when it reads a file (once per path, not once per
/// object), so components that each place the one below twice, 40 deep, keep it busy for ever;
/// a part whose objects unfold into more than kMostPlaced meshes is refused before it sees it.
class ComponentScan {
 public:
  void feed(const char* p, std::size_t n) {
    for (std::size_t i = 0; i < n; ++i) {
      const char c = p[i];
      if (!in_tag_) {
        if (c == '<') {
          in_tag_ = true;
          tag_.clear();
        }
        continue;
      }
      if (c == '>') {
        in_tag_ = false;
        take(tag_);
      } else if (tag_.size() < kLongestTag) {
        tag_ += c;
      }
    }
  }

  /// Why the part is refused, or "".
  std::string verdict() const {
    // Meshes under each object, saturated at kMostPlaced + 1; depth first without recursion.
    std::map<long long, std::size_t> count;
    std::map<long long, int> state;  // 1: on the path, 2: counted
    for (const auto& [root, unused] : parts_) {
      if (state[root] == 2) continue;
      std::vector<std::pair<long long, std::size_t>> stack = {{root, 0}};
      state[root] = 1;
      while (!stack.empty()) {
        auto& [object, next] = stack.back();
        const auto it = parts_.find(object);
        if (it != parts_.end() && next < it->second.size()) {
          const long long child = it->second[next++];
          if (state[child] == 1) return "has components that place each other in a cycle";
          if (state[child] == 0) {
            state[child] = 1;
            stack.emplace_back(child, 0);
          }
          continue;
        }
        std::size_t total = it == parts_.end() || it->second.empty() ? 1 : 0;
        if (it != parts_.end())
          for (long long child : it->second) {
            const auto c = count.find(child);
            total = std::min(kMostPlaced + 1, total + (c == count.end() ? 1 : c->second));
          }
        count[object] = total;
        state[object] = 2;
        stack.pop_back();
      }
      if (count[root] > kMostPlaced)
        return "nests components into more than " + std::to_string(kMostPlaced) +
               " copies of its meshes";
    }
    return "";
  }

 private:
  static constexpr std::size_t kLongestTag = 4096;

  // The value of attribute `name` in the tag's text, or -1.
  static long long attribute(const std::string& tag, const char* name) {
    const std::size_t len = std::strlen(name);
    for (std::size_t at = tag.find(name); at != std::string::npos; at = tag.find(name, at + 1)) {
      if (at == 0 || !std::isspace(static_cast<unsigned char>(tag[at - 1]))) continue;
      std::size_t i = at + len;
      while (i < tag.size() && std::isspace(static_cast<unsigned char>(tag[i]))) ++i;
      if (i >= tag.size() || tag[i] != '=') continue;
      ++i;
      while (i < tag.size() && std::isspace(static_cast<unsigned char>(tag[i]))) ++i;
      if (i >= tag.size() || (tag[i] != '"' && tag[i] != '\'')) continue;
      return std::atoll(tag.c_str() + i + 1);
    }
    return -1;
  }

  // The tag's name without its namespace prefix ("m:object" -> "object").
  static std::string name_of(const std::string& tag) {
    std::size_t end = 0;
    while (end < tag.size() && !std::isspace(static_cast<unsigned char>(tag[end])) &&
           tag[end] != '/')
      ++end;
    if (end == 0 && !tag.empty() && tag[0] == '/') {
      end = 1;
      while (end < tag.size() && !std::isspace(static_cast<unsigned char>(tag[end]))) ++end;
    }
    std::string name = tag.substr(0, end);
    const std::size_t colon = name.find(':');
    if (colon != std::string::npos) name = (name[0] == '/' ? "/" : "") + name.substr(colon + 1);
    return name;
  }

  void take(const std::string& tag) {
    const std::string name = name_of(tag);
    if (name == "object") {
      object_ = attribute(tag, "id");
      parts_[object_];
      if (!tag.empty() && tag.back() == '/') object_ = -1;
    } else if (name == "/object") {
      object_ = -1;
    } else if (name == "component" && object_ >= 0) {
      parts_[object_].push_back(attribute(tag, "objectid"));
    }
  }

  bool in_tag_ = false;
  std::string tag_;
  long long object_ = -1;
  std::map<long long, std::vector<long long>> parts_;  // object -> the objects it places
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
      ComponentScan components;
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
        components.feed(buffer.data(), std::size_t(n));
      }
      zip_fclose(f);
      if (const std::string why = components.verdict(); !why.empty()) {
        const char* name = zip_get_name(archive.get(), zip_uint64_t(i), 0);
        return "refused: the part '" + std::string(name ? name : "?") + "' " + why +
               " (lib3mf, which reads 3MF files, walks every one of them)";
      }
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

/// A build item's or a component's transform as a placement (the same layout).
Placement placement_of(const MODELTRANSFORM& t) {
  Placement m;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) m[r * 4 + c] = t.m_fFields[r][c];
  return m;
}

/// `outer` after the transform `handle` carries, if any (`has` and `get`: lib3mf's pair of
/// functions for a build item or a component), into `out`; "" or what failed.
template <class Has, class Get>
std::string placed_by(PLib3MFBase* handle, Has has, Get get, const Placement& outer,
                      Placement& out) {
  BOOL moved = false;
  MODELTRANSFORM t;
  if (has(handle, &moved) != LIB3MF_OK || (moved && get(handle, &t) != LIB3MF_OK))
    return last_error(handle);
  out = moved ? compose(outer, placement_of(t)) : outer;
  return "";
}

/// Calls f(mesh object, placement) for each mesh the object `object` holds placed by `place`:
/// itself, or a components object's components (each by its own transform, recursively).
template <class F>
std::string each_part(PLib3MFBase* object, const Placement& place, int depth, F&& f) {
  if (depth > 64) return "components nested more than 64 deep";
  BOOL is_mesh = false, is_components = false;
  if (lib3mf_object_ismeshobject(object, &is_mesh) != LIB3MF_OK ||
      lib3mf_object_iscomponentsobject(object, &is_components) != LIB3MF_OK)
    return last_error(object);
  if (is_mesh) return f(object, place);
  if (!is_components) return "";
  DWORD count = 0;
  if (lib3mf_componentsobject_getcomponentcount(object, &count) != LIB3MF_OK)
    return last_error(object);
  for (DWORD i = 0; i < count; ++i) {
    Handle component, child;
    if (lib3mf_componentsobject_getcomponent(object, i, component.out()) != LIB3MF_OK ||
        lib3mf_component_getobjectresource(component.get(), child.out()) != LIB3MF_OK)
      return last_error(object);
    Placement inner;
    std::string why = placed_by(component.get(), lib3mf_component_hastransform,
                                lib3mf_component_gettransform, place, inner);
    if (why.empty()) why = each_part(child.get(), inner, depth + 1, f);
    if (!why.empty()) return why;
  }
  return "";
}

/// Calls f(mesh object, placement) for each mesh the build places (3MF 1.x, 3.4.1: what is
/// printed is the build items, each object by its transform); a model whose build places no
/// mesh: every mesh object as it is. At most kMostPlaced meshes (components nest, so a small
/// file could place exponentially many).
template <class F>
std::string each_placed(void* model_handle, F&& f) {
  auto* model = static_cast<PLib3MFBase*>(model_handle);
  Handle items;
  if (lib3mf_model_getbuilditems(model, items.out()) != LIB3MF_OK) return last_error(model);
  std::size_t placed = 0;
  BOOL has_next = false;
  while (lib3mf_builditemiterator_movenext(items.get(), &has_next) == LIB3MF_OK && has_next) {
    Handle item, object;
    if (lib3mf_builditemiterator_getcurrent(items.get(), item.out()) != LIB3MF_OK ||
        lib3mf_builditem_getobjectresource(item.get(), object.out()) != LIB3MF_OK)
      return last_error(items.get());
    Placement place;
    std::string why = placed_by(item.get(), lib3mf_builditem_hasobjecttransform,
                                lib3mf_builditem_getobjecttransform, kUnmoved, place);
    if (!why.empty()) return why;
    why = each_part(object.get(), place, 0, [&](PLib3MFBase* mesh, const Placement& at) {
      if (++placed > kMostPlaced) return std::string("the build places more than a million meshes");
      return f(mesh, at);
    });
    if (!why.empty()) return why;
  }
  if (placed) return "";
  return each_object(model, [&](PLib3MFBase* object) { return f(object, kUnmoved); });
}

std::string sizes(void* model, std::vector<std::array<std::size_t, 2>>& out) {
  try {
    out.clear();
    return each_placed(model, [&](PLib3MFBase* object, const Placement&) -> std::string {
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
    return each_placed(model, [&](PLib3MFBase* object, const Placement& m) -> std::string {
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
      if (m != kUnmoved) {
        place_positions(m, positions + base_v, nv);
        keep_outward(m, triangles + base_f, nf);
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
