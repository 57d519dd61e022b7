#pragma once
// Shared pieces of the Python binding qjulia._core (module.cpp, mesh_object.cpp).
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "qjulia_api.h"

namespace qjulia::python {

namespace py = pybind11;

/// The progress and the cancellation of one call that runs with the GIL released
/// (run_watched()). The work reports through it from any thread and checks token().
class Watch {
 public:
  /// One progress report of the work.
  struct Report {
    std::string stage;
    double fraction = 0;
    bool operator==(const Report& o) const { return stage == o.stage && fraction == o.fraction; }
  };

  /// Records the progress of the work; false once the call is cancelled (return it from a
  /// library progress callback).
  bool report(const std::string& stage, double fraction);
  /// A library ProgressFn reporting under `stage`.
  ProgressFn progress_fn(std::string stage);
  /// The token the work checks (its options' `cancel`).
  const CancelToken* token() const { return &token_; }
  /// Asks the work to stop.
  void cancel() noexcept { token_.request(); }
  /// The reports since the last call: the first of every stage begun since, then the latest
  /// (so no stage is missed, however short).
  std::vector<Report> take();
  /// The latest report; its stage is "" before the first one.
  Report latest();

 private:
  CancelToken token_;
  std::mutex mutex_;
  std::vector<Report> starts_;  // first reports of the stages begun since take()
  Report latest_;
  bool fresh_ = false;  // a report came since take()
};

/// How run_watched() ends when a Python exception (Ctrl-C) interrupts the work.
enum class OnInterrupt {
  kWait,    ///< when the work has stopped (it uses the caller's objects)
  kDetach,  ///< when the work has stopped, or after 0.5 s, leaving the cancelled work to stop
            ///< on its own (it must own everything it uses); the interpreter's exit waits for it
};

/// Runs `work` on a worker thread while the calling thread, with the GIL released, waits. Every
/// 50 ms the calling thread takes the GIL for a moment: it runs Python's signal handlers
/// (PyErr_CheckSignals, so Ctrl-C raises KeyboardInterrupt), checks `cancel` (a
/// qjulia.CancelToken or None) and calls `progress(stage, fraction)` (a callable or None) with
/// the reports Watch::take() gives, or with the latest again when 0.25 s passed without one;
/// the reports left when the work ends are delivered after it. A Python exception (from a signal
/// handler or the callback), a callback returning False and a requested `cancel` request the
/// work's token. When
/// the work has stopped (see OnInterrupt), a Python exception is re-raised (the work's Cancelled
/// is dropped); otherwise the work's own exception is rethrown.
/// @throws py::type_error when `progress` is not callable or `cancel` not a CancelToken.
void run_watched(std::function<void(Watch&)> work, const py::object& progress,
                 const py::object& cancel, OnInterrupt on_interrupt = OnInterrupt::kWait);

/// Waits for the work left running by OnInterrupt::kDetach (at the interpreter's exit).
void wait_for_detached_work();

/// A mesh handed to Python. When it was made from parameters it keeps their JSON (recorded by
/// save(), as `qjulia mesh` records them), the --stats JSON of its run and, with vdb=True, the
/// sampled grid.
struct PyMesh {
  TriMesh mesh;
  std::string params_json;  ///< the parameter file it was made from; "" when unknown
  std::string stats_json;   ///< the --stats JSON of its run; "" when not made by mesh()
  std::string unit;         ///< "mm" when scaled by print.size_mm, else ""
  std::optional<SampledGrid> grid;
};

/// Raises ValueError for a path with a NUL character (as Python's open() does): the C library
/// would take the part before it.
void check_path(const std::string& path);

/// Raises OSError (FileNotFoundError, PermissionError, IsADirectoryError, ...) naming `path`
/// when it cannot be opened for reading; ValueError for a NUL in it (check_path()).
void check_readable(const std::string& path);

/// Raises OSError (FileNotFoundError, NotADirectoryError, PermissionError, IsADirectoryError)
/// naming `path` when no file can be created there: the library reports that as bad input
/// (the CLI's exit code 2), Python as a file problem.
void check_writable(const std::string& path);

/// os.fspath(path): a str, or the path of an os.PathLike. @throws py::type_error otherwise.
std::string fspath(const py::handle& path);

/// Registers qjulia._core.Mesh, read_mesh() (mesh_object.cpp).
void bind_mesh(py::module_& m);

}  // namespace qjulia::python
