#pragma once
// Exports of `qjulia explore`: a parameter set meshed at full resolution into a file, on a
// thread of its own, with progress, cancel and a download when done. One export runs at a
// time; the server keeps the newest job (and its file) only.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>

#include "qjulia/base/progress.h"
#include "qjulia/field/params.h"
#include "qjulia/io/mesh_io.h"

namespace qjulia::explore {

/// Thrown by ExportJobs::start() while another export runs.
class ExportBusy : public std::runtime_error {
 public:
  explicit ExportBusy(std::uint64_t running)
      : std::runtime_error("export " + std::to_string(running) +
                           " is still running; cancel it or wait until it is done"),
        running_(running) {}
  std::uint64_t running() const { return running_; }

 private:
  std::uint64_t running_;
};

/// What a client sees of an export.
struct ExportStatus {
  std::uint64_t id = 0;
  std::string state;          ///< "running", "done", "failed" or "cancelled"
  std::string stage;          ///< the running stage: "sample", "extract", ..., "write"
  double stage_fraction = 0;  ///< of the running stage, 0..1
  double progress = 0;        ///< of the whole job, 0..1 (stages weighted by their usual cost)
  std::string error;          ///< why it failed
  std::string format;         ///< "glb", "gltf", ...
  std::uint64_t bytes = 0;    ///< of the file, when done
  std::size_t faces = 0;      ///< of the mesh, when done
  double seconds = 0;         ///< since the start (until the end when it ended)
};

/// The export jobs of one server.
class ExportJobs {
 public:
  /// @param[in] dir         a private directory for the files (the server's own)
  /// @param[in] max_memory  the memory one export may use, bytes (PipelineOptions::max_memory)
  ExportJobs(std::filesystem::path dir, std::size_t max_memory);
  ~ExportJobs();  ///< cancels the running job and waits for it
  ExportJobs(const ExportJobs&) = delete;
  ExportJobs& operator=(const ExportJobs&) = delete;

  /// Starts meshing `params` (validated by the caller) into `format`. The previous job and its
  /// file are dropped. @return the job's id. @throws ExportBusy while another job runs.
  std::uint64_t start(const Params& params, MeshFormat format);
  /// The status of job `id`, or nothing for an unknown (or dropped) one.
  std::optional<ExportStatus> status(std::uint64_t id) const;
  /// The file of job `id` when it is done, or nothing.
  std::optional<std::filesystem::path> file(std::uint64_t id) const;
  /// Requests the cancel of job `id`. @return false for an unknown job.
  bool cancel(std::uint64_t id);
  /// Cancels the running job, waits for it and refuses later ones.
  void shutdown();

 private:
  struct Job;
  void run(const std::shared_ptr<Job>& job, const Params& params);

  std::filesystem::path dir_;
  std::size_t max_memory_;
  mutable std::mutex mutex_;
  std::shared_ptr<Job> job_;  // the newest
  std::thread thread_;        // of job_
  std::uint64_t next_id_ = 1;
  bool shut_down_ = false;
};

/// The bytes of the file at `path` (one of the server's own). @throws std::runtime_error when
/// it cannot be read.
std::string read_file(const std::filesystem::path& path);

/// Rewrites the .gltf at `path` with its external buffers embedded as base64 data URIs and
/// removes the buffer files, so the file stands alone (a browser download is one file).
/// @throws std::runtime_error when a file cannot be read or written.
void embed_gltf_buffers(const std::filesystem::path& path);

}  // namespace qjulia::explore
