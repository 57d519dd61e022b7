// qjulia._core.Mesh: the TriMesh with numpy views of its arrays, save() for every format of
// `qjulia mesh -o` (and .vdb), and reading mesh files.
#include <pybind11/stl.h>

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <stdexcept>

#include "binding.h"

namespace qjulia::python {
namespace {

// Whether `path` ends in .vdb (any case).
bool is_vdb_path(const std::string& path) {
  if (path.size() < 4) return false;
  std::string ext = path.substr(path.size() - 4);
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext == ".vdb";
}

// A read-only #rows x 3 array over `rows`, kept alive by `owner` (the Python Mesh): no copy.
template <typename T>
py::array_t<T> view(const std::vector<std::array<T, 3>>& rows, const py::handle& owner) {
  py::array_t<T> a({static_cast<py::ssize_t>(rows.size()), py::ssize_t(3)},
                   rows.empty() ? nullptr : rows.front().data(), owner);
  py::detail::array_proxy(a.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
  return a;
}

template <typename T>
py::object optional_view(const std::vector<std::array<T, 3>>& rows, const py::handle& owner) {
  if (rows.empty()) return py::none();
  return view(rows, owner);
}

// Rows of an N x 3 array-like, converted to T (a copy: TriMesh owns its vectors).
template <typename T>
std::vector<std::array<T, 3>> rows_of(const py::handle& obj, const char* name) {
  using Array = py::array_t<T, py::array::c_style | py::array::forcecast>;
  // A cast would drop an imaginary part without a word.
  if (const py::array given = py::array::ensure(obj); given && given.dtype().kind() == 'c')
    throw InvalidInput(std::string(name) + ": expected real numbers, not " +
                       py::str(given.dtype()).cast<std::string>());
  const Array a = Array::ensure(obj);
  if (!a) throw InvalidInput(std::string(name) + ": expected an N x 3 array of numbers");
  if (a.ndim() != 2 || a.shape(1) != 3) {
    std::string shape = "(";
    for (py::ssize_t d = 0; d < a.ndim(); ++d)
      shape += (d ? ", " : "") + std::to_string(a.shape(d));
    throw InvalidInput(std::string(name) + ": expected an N x 3 array, got shape " + shape +
                       (a.ndim() == 1 ? ",)" : ")"));
  }
  std::vector<std::array<T, 3>> out(static_cast<std::size_t>(a.shape(0)));
  if (!out.empty()) std::copy_n(a.data(), out.size() * 3, out.front().data());
  return out;
}

// Faces: an M x 3 array of integers, each a vertex index in 0..vertices-1.
std::vector<std::array<std::uint32_t, 3>> faces_of(const py::handle& obj, std::size_t vertices) {
  const py::array a = py::array::ensure(obj);
  if (!a || (a.dtype().kind() != 'i' && a.dtype().kind() != 'u'))
    throw InvalidInput("faces: expected an M x 3 array of integer vertex indices");
  const auto wide = rows_of<long long>(obj, "faces");
  std::vector<std::array<std::uint32_t, 3>> out(wide.size());
  for (std::size_t f = 0; f < wide.size(); ++f)
    for (int k = 0; k < 3; ++k) {
      const long long v = wide[f][k];
      if (v < 0 || static_cast<unsigned long long>(v) >= vertices)
        throw InvalidInput("faces: face " + std::to_string(f) + " has vertex index " +
                           std::to_string(v) + " but there are " + std::to_string(vertices) +
                           " vertices");
      out[f][k] = static_cast<std::uint32_t>(v);
    }
  return out;
}

std::unique_ptr<PyMesh> mesh_from_arrays(const py::handle& vertices, const py::handle& faces,
                                         const py::object& normals, const py::object& colors) {
  auto out = std::make_unique<PyMesh>();
  out->mesh.positions = rows_of<float>(vertices, "vertices");
  const std::size_t nv = out->mesh.positions.size();
  out->mesh.triangles = faces_of(faces, nv);
  auto optional_rows = [nv](const py::object& arg, const char* name) {
    std::vector<std::array<float, 3>> rows;
    if (arg.is_none()) return rows;
    rows = rows_of<float>(arg, name);
    if (rows.size() != nv)
      throw InvalidInput(std::string(name) + ": " + std::to_string(rows.size()) + " rows for " +
                         std::to_string(nv) + " vertices");
    return rows;
  };
  out->mesh.normals = optional_rows(normals, "normals");
  out->mesh.colors = optional_rows(colors, "colors");
  validate_mesh(out->mesh, "Mesh");  // the check of every mesh that enters the library
  return out;
}

py::object json_or_none(const std::string& text) {
  if (text.empty()) return py::none();
  return py::module_::import("json").attr("loads")(text);
}

// Writes the mesh as `qjulia mesh -o path` does: the parameters recorded in the file (and for
// STL in the sidecar path.json), millimetres when scaled for printing; a .vdb is the grid.
void save(const PyMesh& m, const py::object& path_like, const py::object& progress,
          const py::object& cancel) {
  const std::string path = fspath(path_like);
  const bool vdb = is_vdb_path(path);
  if (vdb && !m.grid)
    throw InvalidInput(path +
                       ": a .vdb file holds the sampled grid, which only a mesh made with "
                       "qjulia.mesh(..., vdb=True) keeps");
  if (!vdb) format_from_path(path);  // an unknown extension fails before any work
  check_writable(path);
  try {
    run_watched(
        [&](Watch& watch) {
          if (vdb) {
            m.grid->write_vdb(path, m.params_json);
            return;
          }
          ExportOptions opts;
          opts.params_json = m.params_json;
          opts.unit = m.unit;
          opts.cancel = watch.token();
          opts.progress = watch.progress_fn("save");
          write_mesh(path, m.mesh, opts);
          if (format_from_path(path) != MeshFormat::kStl || m.params_json.empty()) return;
          try {  // STL has no room for the parameters: a sidecar file, as the CLI writes it
            AtomicFile sidecar(path + ".json");
            sidecar.write(m.params_json);
            sidecar.commit();
          } catch (...) {
            std::remove(path.c_str());  // all files or none
            throw;
          }
        },
        progress, cancel);
  } catch (const Cancelled&) {
    throw;
  } catch (const std::runtime_error& e) {  // the writers' failures: no directory, disk full...
    PyErr_SetString(PyExc_OSError, e.what());
    throw py::error_already_set();
  }
}

std::unique_ptr<PyMesh> read(const std::string& path) {
  check_readable(path);
  auto out = std::make_unique<PyMesh>();
  py::gil_scoped_release release;
  out->mesh = read_mesh(path);
  out->params_json = read_mesh_params(path);
  return out;
}

}  // namespace

void bind_mesh(py::module_& m) {
  py::class_<PyMesh>(m, "Mesh", R"(A triangle mesh in slice coordinates (x, y, z as sampled).

Mesh(vertices, faces, *, normals=None, colors=None) makes one from arrays (copied);
qjulia.mesh() and qjulia.load() return them too. The array properties are read-only
views of the mesh's own memory (no copy).)")
      .def(py::init(&mesh_from_arrays), py::arg("vertices"), py::arg("faces"), py::kw_only(),
           py::arg("normals") = py::none(), py::arg("colors") = py::none())
      .def_property_readonly(
          "vertices",
          [](py::object self) { return view(self.cast<PyMesh&>().mesh.positions, self); },
          "N x 3 float32 positions.")
      .def_property_readonly(
          "faces", [](py::object self) { return view(self.cast<PyMesh&>().mesh.triangles, self); },
          "M x 3 uint32 vertex indices, counter-clockwise seen from outside.")
      .def_property_readonly(
          "normals",
          [](py::object self) { return optional_view(self.cast<PyMesh&>().mesh.normals, self); },
          "N x 3 float32 unit normals, or None.")
      .def_property_readonly(
          "colors",
          [](py::object self) { return optional_view(self.cast<PyMesh&>().mesh.colors, self); },
          "N x 3 float32 linear RGB in [0, 1] (mesh={'color': 'iterations' or 'basin'}), or "
          "None.")
      .def_property_readonly(
          "stats", [](const PyMesh& self) { return json_or_none(self.stats_json); },
          "The dict `qjulia mesh --stats` writes for the same parameters, or None.")
      .def_property_readonly(
          "params", [](const PyMesh& self) { return json_or_none(self.params_json); },
          "The parameter file (dict) the mesh was made from, or None when unknown.")
      .def_property_readonly(
          "unit", [](const PyMesh& self) { return self.unit; },
          "'mm' when scaled by print.size_mm, else '' (model units).")
      .def_property_readonly(
          "has_grid", [](const PyMesh& self) { return self.grid.has_value(); },
          "True when made with vdb=True: save() can write a .vdb.")
      .def("save", &save, py::arg("path"), py::kw_only(), py::arg("progress") = py::none(),
           py::arg("cancel") = py::none(),
           R"(Writes the mesh as `qjulia mesh -o PATH` does (.glb .gltf .obj .ply .stl .3mf, the
format by the extension; the parameters recorded as the CLI records them, for STL in
PATH.json); .vdb writes the sampled grid (only for a mesh made with vdb=True).
Raises ValueError for a bad extension or an empty mesh, OSError when writing fails.)")
      .def("__repr__", [](const PyMesh& self) {
        return "<qjulia.Mesh " + std::to_string(self.mesh.positions.size()) + " vertices, " +
               std::to_string(self.mesh.triangles.size()) + " faces>";
      });
  m.attr("Mesh").attr("__module__") = "qjulia";
  m.def("read_mesh", &read, py::arg("path"),
        "Reads a mesh file (any format save() writes), with the parameters it records.");
}

}  // namespace qjulia::python
