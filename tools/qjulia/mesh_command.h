#pragma once
// The `mesh` command's arguments and its files besides the mesh, shared by `qjulia mesh` and
// `qjulia-mpi mesh` (the same options, the same outputs).
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "cli.h"
#include "files.h"
#include "qjulia/base/mesh.h"
#include "qjulia/field/params.h"
#include "qjulia/pipeline/pipeline.h"
#include "qjulia/render/render.h"

namespace qjulia::cli {

/// What `mesh` was asked for, parsed and checked before any work: every number in its range,
/// the output format known, every output claimed (not an input, not a directory or device).
struct MeshCommand {
  std::string program;  ///< "qjulia mesh", for messages
  ParsedArgs args;
  std::string out;
  Params params;
  std::string params_json;
  std::optional<std::string> preview, stats_path, vdb;  ///< stats_path "-": standard output
  RenderOptions preview_options;
  PipelineOptions pipeline;  ///< without progress
  std::unique_ptr<ThreadLimit> threads;
  OutputFiles written;  ///< removed again unless committed
};

/// What follows empty_solid_message() when `mesh` writes nothing because the solid is empty.
extern const char* const kEmptySolidHint;

/// Why `mesh` writes nothing when its run gave no faces: an empty solid (with the hint) or a
/// surface whose every component was dust.
std::string nothing_written(const Params& params, const RunStats& stats);

/// Parses the arguments of `mesh`; null when --help was asked for (and printed). `program`
/// names the command in the help ("qjulia mesh").
/// @throws InvalidInput (exit 2).
std::unique_ptr<MeshCommand> parse_mesh_command(const std::vector<std::string>& tokens,
                                                const CancelToken& cancel,
                                                const std::string& program);

/// After the mesh was written: the STL sidecar with the parameters, the preview (of `mesh`),
/// the stats file; commits every output and prints the summary. `extra` is printed after it.
void finish_mesh_command(MeshCommand& cmd, RunStats& stats, const TriMesh* mesh,
                         const CancelToken& cancel);

/// Ends the process with `code` once every output is committed and the summary printed,
/// without freeing the run's memory (hundreds of megabytes of mesh take a noticeable time to
/// give back, for nothing). Sanitizer builds return normally, so the leak check still runs.
[[noreturn]] void exit_without_freeing(int code);

}  // namespace qjulia::cli
