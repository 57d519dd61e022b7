// qjulia._core: the library in-process for Python. The public API is the package qjulia
// (python/qjulia/__init__.py), which builds the parameter files and calls these functions.
#include <pybind11/stl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <condition_variable>
#include <exception>
#include <initializer_list>
#include <stdexcept>
#include <thread>
#include <vector>

#include "binding.h"

namespace qjulia::python {
namespace {

using Clock = std::chrono::steady_clock;
constexpr auto kPollInterval = std::chrono::milliseconds(50);
constexpr auto kHeartbeat = std::chrono::milliseconds(250);
// How long a call interrupted by Ctrl-C waits for detachable work to stop (OnInterrupt).
constexpr auto kDetachGrace = std::chrono::milliseconds(500);

// qjulia.Cancelled, created in the module init and alive as long as the interpreter.
PyObject* g_cancelled_type = nullptr;

// The library's exceptions as the Python exceptions of the issue: a memory refusal is a
// MemoryError, other bad input a ValueError with the CLI's message.
void translate_exception(std::exception_ptr p) {
  try {
    if (p) std::rethrow_exception(p);
  } catch (const TooLarge& e) {
    PyErr_SetString(PyExc_MemoryError, e.what());
  } catch (const InvalidInput& e) {
    PyErr_SetString(PyExc_ValueError, e.what());
  } catch (const Cancelled& e) {
    PyErr_SetString(g_cancelled_type, e.what());
  }
}

// A Python exception taken off the thread state, to be raised again later.
struct PendingError {
  PyObject *type = nullptr, *value = nullptr, *traceback = nullptr;
  explicit operator bool() const { return type != nullptr; }
  void fetch() { PyErr_Fetch(&type, &value, &traceback); }
  [[noreturn]] void raise() {
    PyErr_Restore(type, value, traceback);
    throw py::error_already_set();
  }
};

// Calls progress(stage, fraction) with the GIL held; false when the call raised (then fetched
// into `error`) or returned False.
bool call_progress(const py::object& progress, const std::string& stage, double fraction,
                   PendingError& error) {
  PyObject* r = PyObject_CallFunction(progress.ptr(), "sd", stage.c_str(), fraction);
  if (!r) {
    error.fetch();
    return false;
  }
  const bool go_on = r != Py_False;
  Py_DECREF(r);
  return go_on;
}

std::unique_ptr<PyMesh> run_mesh(const std::string& params_json, const py::object& progress,
                                 const py::object& cancel, bool dense, bool vdb,
                                 std::optional<std::size_t> max_memory) {
  // Owned by the work, which Ctrl-C may leave to stop on its own.
  auto params = std::make_shared<const Params>(parse_params(params_json, "parameters"));
  auto out = std::make_shared<PyMesh>();
  run_watched(
      [params, out, dense, vdb, max_memory](Watch& watch) {
        PipelineOptions opts;
        opts.dense = dense;
        opts.keep_grid = vdb;
        opts.max_memory = max_memory;
        opts.cancel = watch.token();
        opts.progress = [&watch](const std::string& stage, double f) {
          return watch.report(stage, f);
        };
        PipelineResult r = run_pipeline(*params, opts);
        r.stats.peak_rss_bytes = peak_rss_bytes();  // as `qjulia mesh --stats` writes it
        out->stats_json = stats_to_json(r.stats, *params);
        out->params_json = params_to_json(*params);
        out->unit = r.stats.unit;
        out->mesh = std::move(r.mesh);
        out->grid = std::move(r.grid);
      },
      progress, cancel, OnInterrupt::kDetach);
  return std::make_unique<PyMesh>(std::move(*out));
}

std::string compare_meshes(const PyMesh& a, const PyMesh& b, const std::string& name_a,
                           const std::string& name_b, std::optional<std::size_t> samples,
                           std::optional<std::uint64_t> seed, const py::object& progress,
                           const py::object& cancel) {
  CompareOptions opts;
  if (samples) opts.samples = *samples;
  if (seed) opts.seed = *seed;
  std::string json;
  run_watched(
      [&](Watch& watch) {
        opts.cancel = watch.token();
        opts.progress = watch.progress_fn("compare");
        json = compare_to_json(compare(a.mesh, b.mesh, opts), name_a, name_b);
      },
      progress, cancel);
  return json;
}

template <std::size_t N, typename T>
std::array<T, N> fixed_array(const py::handle& value, const char* name) {
  const auto v = value.cast<std::vector<T>>();
  if (v.size() != N)
    throw InvalidInput(std::string(name) + ": expected " + std::to_string(N) + " numbers, got " +
                       std::to_string(v.size()));
  std::array<T, N> a{};
  std::copy(v.begin(), v.end(), a.begin());
  return a;
}

// The value named by the string `value` among `choices`.
// @throws InvalidInput naming `option` and the names it accepts.
template <typename E>
E choice(const py::handle& value, const char* option,
         std::initializer_list<std::pair<const char*, E>> choices) {
  const auto s = value.cast<std::string>();
  std::string names;
  std::size_t i = 0;
  for (const auto& [name, e] : choices) {
    if (s == name) return e;
    if (i > 0) names += i + 1 == choices.size() ? " or " : ", ";
    names += name;
    ++i;
  }
  throw InvalidInput(std::string(option) + ": '" + s + "' is not " + names);
}

// RenderOptions from keyword arguments named as its members (vertex_colors for
// use_vertex_colors); the library's defaults where absent.
RenderOptions render_options(const py::kwargs& kwargs) {
  RenderOptions o;
  for (const auto& [key, value] : kwargs) {
    const std::string k = key.cast<std::string>();
    if (k == "width") {
      o.width = value.cast<int>();
    } else if (k == "height") {
      o.height = value.cast<int>();
    } else if (k == "shading") {
      o.shading = choice<Shading>(value, "shading",
                                  {{"simple", Shading::kSimple},
                                   {"lambert", Shading::kLambert},
                                   {"phong", Shading::kPhong}});
    } else if (k == "lights") {
      o.lights.clear();
      for (const auto& l : value) o.lights.push_back(fixed_array<3, double>(l, "lights"));
    } else if (k == "ambient") {
      o.ambient = value.cast<double>();
    } else if (k == "specular") {
      o.specular = value.cast<double>();
    } else if (k == "shininess") {
      o.shininess = value.cast<double>();
    } else if (k == "rotate") {
      o.rotate_deg = fixed_array<3, double>(value, "rotate");
    } else if (k == "background") {
      const auto b = fixed_array<3, int>(value, "background");
      for (int i = 0; i < 3; ++i) {
        if (b[i] < 0 || b[i] > 255) throw InvalidInput("background: values must be in 0..255");
        o.background[i] = static_cast<std::uint8_t>(b[i]);
      }
    } else if (k == "color") {
      o.color = fixed_array<3, double>(value, "color");
    } else if (k == "vertex_colors") {
      o.use_vertex_colors = value.cast<bool>();
    } else if (k == "framing") {
      o.framing =
          choice<Framing>(value, "framing", {{"box", Framing::kBox}, {"sphere", Framing::kSphere}});
    } else if (k == "margin") {
      o.margin = value.cast<double>();
    } else if (k == "supersample") {
      o.supersample = value.cast<int>();
    } else {
      throw py::type_error(
          "render() got an unexpected keyword argument '" + k +
          "' (known: width, height, shading, lights, ambient, specular, shininess, rotate, "
          "background, color, vertex_colors, framing, margin, supersample)");
    }
  }
  check_render_options(o);
  return o;
}

// The image as an H x W x 3 uint8 array over the image's own buffer.
py::array_t<std::uint8_t> render_mesh(const PyMesh& mesh, const py::kwargs& kwargs) {
  const RenderOptions opts = render_options(kwargs);
  auto image = std::make_unique<Image>();
  {
    py::gil_scoped_release release;
    *image = render(mesh.mesh, opts);
  }
  const py::ssize_t h = image->height, w = image->width;
  std::uint8_t* data = image->rgb.data();
  py::capsule owner(image.release(), [](void* p) { delete static_cast<Image*>(p); });
  return py::array_t<std::uint8_t>({h, w, py::ssize_t(3)}, data, owner);
}

// Writes an H x W x 3 uint8 array as a PNG, as `qjulia render` writes its images.
void save_png(const py::object& path_like, const py::handle& pixels) {
  const std::string path = fspath(path_like);
  if (!is_png_path(path)) throw InvalidInput(path + ": must end in .png (the image is a PNG)");
  const py::array given = py::array::ensure(pixels);
  if (!given || given.ndim() != 3 || given.shape(2) != 3)
    throw InvalidInput("image: expected an H x W x 3 array of uint8");
  // Other integer types only when every value is a byte (a cast would wrap them silently).
  const char kind = given.dtype().kind();
  if (kind != 'u' && kind != 'i')
    throw InvalidInput("image: expected uint8 values 0..255, not " +
                       py::str(given.dtype()).cast<std::string>());
  if (given.dtype().itemsize() > 1 || kind == 'i') {
    using Wide = py::array_t<long long, py::array::c_style | py::array::forcecast>;
    const Wide wide = Wide::ensure(given);
    const auto* v = wide.data();
    for (py::ssize_t i = 0; i < wide.size(); ++i)
      if (v[i] < 0 || v[i] > 255)
        throw InvalidInput("image: value " + std::to_string(v[i]) + " is not in 0..255");
  }
  using Array = py::array_t<std::uint8_t, py::array::c_style | py::array::forcecast>;
  const Array a = Array::ensure(given);
  Image image;
  image.height = static_cast<int>(a.shape(0));
  image.width = static_cast<int>(a.shape(1));
  image.rgb.assign(a.data(), a.data() + a.size());
  check_writable(path);
  try {
    py::gil_scoped_release release;
    write_png(path, image);
  } catch (const std::runtime_error& e) {
    PyErr_SetString(PyExc_OSError, e.what());
    throw py::error_already_set();
  }
}

// Test hook: throws the library's exception of `kind`, so the tests see every translation.
void throw_for_test(const std::string& kind, const std::string& message) {
  if (kind == "InvalidInput") throw InvalidInput(message);
  if (kind == "TooLarge") throw TooLarge(message);
  if (kind == "Cancelled") throw Cancelled();
  if (kind == "runtime_error") throw std::runtime_error(message);
  throw std::logic_error("unknown kind " + kind);
}

}  // namespace

bool Watch::report(const std::string& stage, double fraction) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stage != latest_.stage) starts_.push_back({stage, fraction});
    latest_ = {stage, fraction};
    fresh_ = true;
  }
  return !token_.requested();
}

ProgressFn Watch::progress_fn(std::string stage) {
  return [this, stage = std::move(stage)](double f) { return report(stage, f); };
}

std::vector<Watch::Report> Watch::take() {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<Report> out = std::move(starts_);
  starts_.clear();
  if (fresh_ && (out.empty() || !(out.back() == latest_))) out.push_back(latest_);
  fresh_ = false;
  return out;
}

Watch::Report Watch::latest() {
  std::lock_guard<std::mutex> lock(mutex_);
  return latest_;
}

namespace {

// One call of run_watched(): shared by the calling thread and the worker, which may outlive the
// call (OnInterrupt::kDetach).
struct WatchedRun {
  std::function<void(Watch&)> work;
  Watch watch;
  std::exception_ptr failure;
  std::mutex mutex;
  std::condition_variable finished;
  bool done = false;

  bool wait_for(std::chrono::milliseconds timeout) {
    std::unique_lock<std::mutex> lock(mutex);
    return finished.wait_for(lock, timeout, [&] { return done; });
  }
};

// The cancelled runs that OnInterrupt::kDetach left running.
std::mutex g_detached_mutex;
std::vector<std::shared_ptr<WatchedRun>> g_detached;

void detach(std::thread& worker, std::shared_ptr<WatchedRun> run) {
  worker.detach();
  std::lock_guard<std::mutex> lock(g_detached_mutex);
  g_detached.erase(std::remove_if(g_detached.begin(), g_detached.end(),
                                  [](const auto& r) { return r->wait_for({}); }),
                   g_detached.end());
  g_detached.push_back(std::move(run));
}

}  // namespace

void wait_for_detached_work() {
  std::vector<std::shared_ptr<WatchedRun>> runs;
  {
    std::lock_guard<std::mutex> lock(g_detached_mutex);
    runs.swap(g_detached);
  }
  py::gil_scoped_release release;
  for (const auto& run : runs)
    while (!run->wait_for(std::chrono::seconds(1))) {
    }
}

void run_watched(std::function<void(Watch&)> work, const py::object& progress,
                 const py::object& cancel, OnInterrupt on_interrupt) {
  if (!progress.is_none() && !PyCallable_Check(progress.ptr()))
    throw py::type_error("progress must be a callable (stage, fraction) or None");
  if (!cancel.is_none() && !py::isinstance<CancelToken>(cancel))
    throw py::type_error("cancel must be a qjulia.CancelToken or None");
  const CancelToken* user_token = cancel.is_none() ? nullptr : cancel.cast<const CancelToken*>();
  auto run = std::make_shared<WatchedRun>();
  run->work = std::move(work);
  Watch& watch = run->watch;
  if (user_token && user_token->requested()) watch.cancel();
  PendingError python_error;
  {
    py::gil_scoped_release release;
    std::thread worker([run] {
      try {
        run->work(run->watch);
      } catch (...) {
        run->failure = std::current_exception();
      }
      std::lock_guard<std::mutex> lock(run->mutex);
      run->done = true;
      run->finished.notify_all();
    });
    Clock::time_point last_call = Clock::now();
    // Calls the callback with the new reports (or the latest again after kHeartbeat); false
    // when it raised or returned False.
    auto deliver = [&](bool heartbeat) {
      std::vector<Watch::Report> reports = watch.take();
      if (reports.empty() && heartbeat && Clock::now() - last_call >= kHeartbeat) {
        Watch::Report r = watch.latest();
        if (!r.stage.empty()) reports.push_back(std::move(r));
      }
      if (!reports.empty()) last_call = Clock::now();
      for (const auto& r : reports)
        if (!call_progress(progress, r.stage, r.fraction, python_error)) return false;
      return true;
    };
    while (!run->wait_for(kPollInterval)) {
      if (user_token && user_token->requested()) watch.cancel();
      if (python_error) {
        if (on_interrupt == OnInterrupt::kDetach && !run->wait_for(kDetachGrace)) {
          detach(worker, run);  // cancelled: it stops on its own, owning what it uses
          break;
        }
        continue;
      }
      py::gil_scoped_acquire gil;
      if (PyErr_CheckSignals() != 0) {
        python_error.fetch();
        watch.cancel();
      } else if (!progress.is_none() && !deliver(true)) {
        watch.cancel();
      }
    }
    if (worker.joinable()) worker.join();
    if (!python_error && !run->failure && !progress.is_none()) {
      py::gil_scoped_acquire gil;
      deliver(false);  // the last stages; the work is done, so False changes nothing
    }
  }
  if (python_error) python_error.raise();
  if (run->failure) std::rethrow_exception(run->failure);
}

void check_path(const std::string& path) {
  // The C library would read or write the file named by the part before the NUL.
  if (path.find('\0') != std::string::npos) throw py::value_error("embedded null byte");
}

void check_readable(const std::string& path) {
  check_path(path);
  std::FILE* f = std::fopen(path.c_str(), "rb");
  struct stat st {};
  const bool is_dir = f && ::stat(path.c_str(), &st) == 0 && S_ISDIR(st.st_mode);
  if (f) std::fclose(f);
  if (f && !is_dir) return;
  if (is_dir) errno = EISDIR;  // fopen opens a directory; reading it fails
  PyErr_SetFromErrnoWithFilename(PyExc_OSError, path.c_str());
  throw py::error_already_set();
}

void check_writable(const std::string& path) {
  check_path(path);
  const auto slash = path.find_last_of('/');
  const std::string dir = slash == std::string::npos ? "." : path.substr(0, slash ? slash : 1);
  struct stat st {};
  int error = 0;
  if (::stat(dir.c_str(), &st) != 0)
    error = errno;
  else if (!S_ISDIR(st.st_mode))
    error = ENOTDIR;
  else if (::access(dir.c_str(), W_OK | X_OK) != 0)
    error = errno;
  else if (::stat(path.c_str(), &st) == 0 && S_ISDIR(st.st_mode))
    error = EISDIR;
  if (!error) return;
  errno = error;
  PyErr_SetFromErrnoWithFilename(PyExc_OSError, path.c_str());
  throw py::error_already_set();
}

std::string fspath(const py::handle& path) {
  return py::module_::import("os").attr("fspath")(path).cast<std::string>();
}

}  // namespace qjulia::python

PYBIND11_MODULE(_core, m) {
  using namespace qjulia;
  using namespace qjulia::python;
  m.doc() = "The compiled part of qjulia; use the package qjulia.";

  g_cancelled_type = PyErr_NewExceptionWithDoc(
      "qjulia.Cancelled",
      "Raised when a progress callback returned False or a CancelToken was requested.", nullptr,
      nullptr);
  if (!g_cancelled_type) throw py::error_already_set();
  m.add_object("Cancelled", py::handle(g_cancelled_type));
  py::register_exception_translator(&translate_exception);
  // Work that Ctrl-C left to stop on its own ends before the interpreter does.
  py::module_::import("atexit").attr("register")(py::cpp_function(&wait_for_detached_work));

  py::class_<CancelToken>(m, "CancelToken",
                          "Cancels the calls it is given to (cancel=token), from any thread.")
      .def(py::init<>())
      .def("request", &CancelToken::request, "Asks the work to stop (it raises Cancelled).")
      .def_property_readonly("requested", &CancelToken::requested)
      .def("reset", &CancelToken::reset, "Clears the request, for the next call.");

  bind_mesh(m);

  m.def("version", [] { return std::string(version()); });
  m.def("preset_names", &preset_names);
  m.def("preset_description", &preset_description, py::arg("name"));
  m.def(
      "preset_json", [](const std::string& name) { return params_to_json(preset(name)); },
      py::arg("name"), "The preset as a parameter file (JSON).");
  m.def(
      "params_file_json",
      [](const std::string& path) {
        check_readable(path);
        return params_to_json(read_params_from(path));
      },
      py::arg("path"),
      "A parameter file, or the one a mesh file records, read, checked and written out complete "
      "(JSON).");
  m.def(
      "normalize_params",
      [](const std::string& json, const std::string& source) {
        return params_to_json(parse_params(json, source));
      },
      py::arg("json"), py::arg("source") = "parameters",
      "Parses and checks a parameter file; returns it complete (JSON).");
  m.def("parse_memory_size", &parse_memory_size, py::arg("text"), py::arg("what"));
  m.def("run_mesh", &run_mesh, py::arg("params_json"), py::arg("progress") = py::none(),
        py::arg("cancel") = py::none(), py::arg("dense") = false, py::arg("vdb") = false,
        py::arg("max_memory") = py::none(),
        "Runs the whole pipeline of `qjulia mesh` on a parameter file (JSON).");
  m.def("compare", &compare_meshes, py::arg("a"), py::arg("b"), py::arg("name_a") = "a",
        py::arg("name_b") = "b", py::arg("samples") = py::none(), py::arg("seed") = py::none(),
        py::arg("progress") = py::none(), py::arg("cancel") = py::none(),
        "The JSON of `qjulia compare --json`.");
  m.def("render", &render_mesh, py::arg("mesh"),
        "Renders a mesh; keyword arguments as the members of RenderOptions.");
  m.attr("MOST_COMPARE_SAMPLES") = py::int_(kMostCompareSamples);
  m.def("save_png", &save_png, py::arg("path"), py::arg("image"),
        "Writes an H x W x 3 uint8 image (render()) as a PNG.");
  m.def("_throw_for_test", &throw_for_test, py::arg("kind"), py::arg("message"));
}
