#pragma once
// Previews of `qjulia explore`: one job at a time, the newest one wins, and the meshes of the
// last few parameter sets are kept for the comparison of two of them.
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <list>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>

#include "qjulia/base/mesh.h"
#include "qjulia/base/progress.h"
#include "qjulia/pipeline/pipeline.h"

namespace qjulia::explore {

/// The message for a run that gave no faces, its solid empty or every component dust (exit 2 of
/// `qjulia mesh` says the same), shown by the page instead of a mesh; and whether a message is
/// one.
std::string empty_solid(const Params& params, const RunStats& stats);
bool says_empty_solid(const std::string& message);

/// Thrown by PreviewLane::run() for a job that a newer one or PreviewLane::stop() ended before
/// or while it ran. The message says which.
class PreviewCancelled : public std::runtime_error {
 public:
  explicit PreviewCancelled(const std::string& why) : std::runtime_error(why) {}
};

/// Runs preview jobs one at a time. A job that arrives while another one runs or waits requests
/// that job's CancelToken, so the stages stop at their next check; the newest job runs next and
/// the older ones end with PreviewCancelled.
class PreviewLane {
 public:
  /// Runs `job` with a token of its own once no other preview runs.
  /// @throws PreviewCancelled when a newer job or stop() ended it; Cancelled after shutdown();
  ///         whatever `job` throws otherwise.
  void run(const std::function<void(const CancelToken&)>& job);
  /// Stops the running job (the page's Stop button). @return whether one was running.
  bool stop();
  /// Stops the running job and refuses every later one (the server is going down).
  void shutdown();

 private:
  std::mutex mutex_;
  std::condition_variable idle_;
  std::uint64_t newest_ = 0;  // ticket of the newest call of run()
  bool running_ = false;
  bool shut_down_ = false;
  std::shared_ptr<CancelToken> token_;  // of the running job
  std::string why_;                     // why token_ was requested
};

/// One meshed parameter set.
struct PreviewMesh {
  TriMesh mesh;
  RunStats stats;
  double seconds = 0;  ///< wall time of run_pipeline()
};

/// The meshes of the last few parameter sets, by their parameter file (params_to_json), so a
/// comparison right after two previews meshes nothing again. Thread-safe.
class MeshCache {
 public:
  explicit MeshCache(std::size_t capacity = 4) : capacity_(capacity) {}
  /// The mesh of `key`, or nullptr.
  std::shared_ptr<const PreviewMesh> find(const std::string& key);
  /// Keeps `mesh` as the newest entry, dropping the oldest beyond the capacity.
  void put(const std::string& key, std::shared_ptr<const PreviewMesh> mesh);

 private:
  std::mutex mutex_;
  std::size_t capacity_;
  std::list<std::pair<std::string, std::shared_ptr<const PreviewMesh>>> entries_;  // newest first
};

}  // namespace qjulia::explore
