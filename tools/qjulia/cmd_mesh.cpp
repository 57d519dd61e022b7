// qjulia mesh: the whole pipeline from parameters to a mesh file and its stats.
#include "commands.h"
#include "mesh_command.h"
#include "progress_bar.h"
#include "qjulia/base/error.h"
#include "qjulia/io/mesh_io.h"
#include "qjulia/pipeline/pipeline.h"

namespace qjulia::cli {

int cmd_mesh(const Tokens& tokens, const CancelToken& cancel) {
  const auto cmd = parse_mesh_command(tokens, cancel, "qjulia mesh");
  if (!cmd) return 0;
  ProgressBar bar(cmd->args.has("quiet"));
  PipelineOptions popts = cmd->pipeline;
  popts.progress = bar.callback();
  // A PLY writer makes the normals while its faces go to the disk; a preview needs them first.
  popts.normals = format_from_path(cmd->out) != MeshFormat::kPly || cmd->preview.has_value();
  PipelineResult result = run_pipeline(cmd->params, popts);

  if (result.mesh.triangles.empty()) throw InvalidInput(nothing_written(cmd->params, result.stats));
  ExportOptions eopts;
  eopts.params_json = cmd->params_json;
  eopts.unit = result.stats.unit;
  eopts.cancel = &cancel;
  eopts.progress = [&bar](double f) {
    bar.update("write", f);
    return true;
  };
  write_mesh(cmd->out, result.mesh, eopts);
  bar.finish();
  if (cmd->vdb) {
    result.grid->write_vdb(*cmd->vdb, cmd->params_json);
    cmd->written.add(*cmd->vdb);
  }
  finish_mesh_command(*cmd, result.stats, &result.mesh, cancel);
  exit_without_freeing(0);
}

}  // namespace qjulia::cli
