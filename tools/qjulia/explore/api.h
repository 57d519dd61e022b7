#pragma once
// The JSON API of `qjulia explore` (docs/explore.md), independent of the HTTP library: each
// route is a function from the request body to a Reply. server.cpp routes requests here.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "export_jobs.h"
#include "preview.h"
#include "qjulia/field/params.h"

namespace qjulia::explore {

/// Accepted "samples" of POST /api/compare.
inline constexpr ValueRange kCompareSamplesRange{1000, 1000000};

/// What the API serves with.
struct ApiOptions {
  Params initial;                    ///< the page's first parameter set (PARAMS.json, --preset)
  std::string initial_name;          ///< its name for the page: the preset or the file name
  int preview_max_resolution = 160;  ///< the largest resolution of a preview, voxels
  std::size_t max_body = 64 * 1024;  ///< the largest request body, bytes
  std::size_t preview_memory = 1u << 30;  ///< max_memory of a preview or comparison, bytes
  std::size_t export_memory = 1u << 30;   ///< max_memory of an export, bytes
  std::filesystem::path work_dir;         ///< the server's private directory for files
};

/// An answer: status, content type, body and extra headers; or a file to send.
struct Reply {
  int status = 200;
  std::string content_type = "application/json";
  std::string body;
  std::vector<std::pair<std::string, std::string>> headers;
  std::optional<std::filesystem::path> file;  ///< sent instead of `body` when set
};

/// The routes. Thread-safe: the server calls them from its worker threads.
class Api {
 public:
  explicit Api(ApiOptions options);

  /// GET /api/info: version, the initial parameter set, the limits, the export formats.
  Reply info() const;
  /// GET /api/presets: [{name, description, params}].
  Reply presets() const;
  /// POST /api/check: {"ok": true, "params"} for a valid parameter file, else {"ok": false,
  /// "error"} plus "key", "line" and "column" when the message names a position.
  Reply check(const std::string& body) const;
  /// POST /api/mesh: the parameter file meshed (resolution at most the preview limit) as GLB,
  /// its figures in the X-Qjulia-Stats header.
  Reply mesh(const std::string& body);
  /// POST /api/compare {"a": params, "b": params, "samples": N}: both meshed as previews and
  /// compared (qjulia compare's JSON).
  Reply compare(const std::string& body);
  /// POST /api/preview/cancel: stops the running preview.
  Reply stop_preview();
  /// POST /api/export {"params", "format"}: starts an export, 202 {"id", ...}.
  Reply start_export(const std::string& body);
  /// GET /api/export/ID: the status of an export.
  Reply export_status(std::uint64_t id) const;
  /// GET /api/export/ID/file: the exported file.
  Reply export_file(std::uint64_t id) const;
  /// POST /api/export/ID/cancel.
  Reply cancel_export(std::uint64_t id);

  /// Stops the running jobs and refuses new ones.
  void shutdown();

  /// Runs `route` and turns what it throws into a JSON error reply: InvalidInput 400 (the
  /// CLI's exit-2 message), PreviewCancelled 409, ExportBusy 409, Cancelled 503, anything else
  /// 500.
  static Reply guarded(const std::function<Reply()>& route);
  /// {"error": message} with `status`.
  static Reply error(int status, const std::string& message);

 private:
  // Parses a parameter set of a preview (`source` names it in messages) and checks its
  // resolution against the preview limit. @throws InvalidInput.
  Params parse_preview(const std::string& json_text, const std::string& source) const;
  // The mesh of `params` (from the cache, else meshed); runs inside a preview job.
  std::shared_ptr<const PreviewMesh> preview_mesh(const Params& params, const std::string& source,
                                                  const CancelToken& cancel, bool* cached);

  ApiOptions options_;
  PreviewLane lane_;
  MeshCache cache_;
  ExportJobs exports_;
  std::string presets_json_;
};

}  // namespace qjulia::explore
