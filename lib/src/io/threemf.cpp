// 3MF writer and reader through lib3mf 1.8 (its C interface). The only file that includes
// lib3mf headers.
#include <Model/COM/NMR_DLLInterfaces.h>

#include <cstring>
#include <fstream>

#include "qjulia/base/atomic_file.h"
#include "io/formats.h"
#include "qjulia/base/error.h"

namespace qjulia::detail {
namespace {

using namespace NMR;

static_assert(sizeof(MODELMESHVERTEX) == 12 && sizeof(MODELMESHTRIANGLE) == 12,
              "lib3mf's vertex and triangle have the layout of TriMesh's arrays");

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

}  // namespace

void write_3mf(const std::string& path, const ExportData& data) {
  const TriMesh& mesh = data.mesh;
  auto check = [&](LIB3MFRESULT r, PLib3MFBase* obj, const char* what) {
    if (r != LIB3MF_OK) throw std::runtime_error(path + ": " + what + ": " + last_error(obj));
  };
  Handle model, object, item, writer;
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
  check(lib3mf_model_addmetadatautf8(model.get(), "Application", data.generator.c_str()),
        model.get(), "adding metadata");
  if (!data.params_json.empty()) {
    check(lib3mf_model_addmetadatautf8(model.get(), kParamsKey, data.params_json.c_str()),
          model.get(), "adding the parameters as metadata");
  }
  check(lib3mf_model_querywriter(model.get(), "3mf", writer.out()), model.get(),
        "creating the writer");
  AtomicFile file(path);
  file.close_for_external();
  check(lib3mf_writer_writetofileutf8(writer.get(), file.temp_path().c_str()), writer.get(),
        "writing");
  file.commit();
}

namespace {

void load(const std::string& path, Handle& model) {
  {
    std::ifstream probe(path);
    if (!probe) read_file(path);
  }  // a clear message when unreadable
  Handle reader;
  if (lib3mf_createmodel(model.out()) != LIB3MF_OK) fail(path, "lib3mf cannot create a model");
  if (lib3mf_model_queryreader(model.get(), "3mf", reader.out()) != LIB3MF_OK) {
    fail(path, "lib3mf cannot create a reader: " + last_error(model.get()));
  }
  if (lib3mf_reader_readfromfileutf8(reader.get(), path.c_str()) != LIB3MF_OK) {
    fail(path, "not a valid 3MF file (" + last_error(reader.get()) + ")");
  }
}

}  // namespace

TriMesh read_3mf(const std::string& path) {
  Handle model, it;
  load(path, model);
  if (lib3mf_model_getmeshobjects(model.get(), it.out()) != LIB3MF_OK)
    fail(path, last_error(model.get()));
  TriMesh mesh;
  BOOL has_next = false;
  while (lib3mf_resourceiterator_movenext(it.get(), &has_next) == LIB3MF_OK && has_next) {
    Handle object;
    if (lib3mf_resourceiterator_getcurrent(it.get(), object.out()) != LIB3MF_OK)
      fail(path, last_error(it.get()));
    DWORD nv = 0, nf = 0;
    if (lib3mf_meshobject_getvertexcount(object.get(), &nv) != LIB3MF_OK ||
        lib3mf_meshobject_gettrianglecount(object.get(), &nf) != LIB3MF_OK) {
      fail(path, last_error(object.get()));
    }
    const std::size_t base_v = mesh.positions.size(), base_f = mesh.triangles.size();
    mesh.positions.resize(base_v + nv);
    mesh.triangles.resize(base_f + nf);
    DWORD got = 0;
    if (nv && lib3mf_meshobject_getvertices(
                  object.get(), reinterpret_cast<MODELMESHVERTEX*>(mesh.positions.data() + base_v),
                  nv, &got) != LIB3MF_OK) {
      fail(path, last_error(object.get()));
    }
    if (nf &&
        lib3mf_meshobject_gettriangleindices(
            object.get(), reinterpret_cast<MODELMESHTRIANGLE*>(mesh.triangles.data() + base_f), nf,
            &got) != LIB3MF_OK) {
      fail(path, last_error(object.get()));
    }
    for (std::size_t f = base_f; f < mesh.triangles.size(); ++f)
      for (auto& i : mesh.triangles[f]) {
        if (i >= nv) fail(path, "a triangle index is out of range");
        i += uint32_t(base_v);
      }
  }
  if (mesh.triangles.empty()) fail(path, "the 3MF file has no triangles");
  return mesh;
}

std::string read_3mf_params(const std::string& path) {
  Handle model;
  load(path, model);
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
