#pragma once
/// @file distributed.h
/// The `qjulia mesh` job across the processes of a distributed run (qjulia-mpi): the bricks
/// are dealt to the ranks in slabs balanced by the coarse lattice's estimate of their cost,
/// each rank samples and meshes its slab with its threads, the ranks agree on the numbering,
/// the components, the dust and the normals, and the mesh is the one run_pipeline() makes, for
/// every number of ranks.
#include <memory>
#include <string>

#include "qjulia/base/comm.h"
#include "qjulia/io/mesh_io.h"
#include "qjulia/pipeline/pipeline.h"

namespace qjulia {

namespace detail {
struct MeshPart;
}

/// Whether the mesh of `params` written as `output` (with a preview or not) stays distributed
/// to the file: a binary PLY or STL written by every rank, with none of the stages that need
/// the whole mesh (decimation, thickening, --size, --check, a preview). Otherwise the mesh is
/// gathered to rank 0 after the dust is removed and those stages run there.
bool stays_distributed(const Params& params, MeshFormat output, bool preview);

/// What run_pipeline_distributed() leaves on a rank.
class DistributedRun {
 public:
  DistributedRun();
  ~DistributedRun();
  DistributedRun(DistributedRun&&) noexcept;
  DistributedRun& operator=(DistributedRun&&) noexcept;

  /// On rank 0: the figures of the whole run (RunStats::ranks has every rank's) and, when
  /// gathered(), the whole mesh. Elsewhere: this rank's figures only, no mesh.
  PipelineResult result;
  /// Whether the mesh was gathered to rank 0.
  bool gathered() const { return part_ == nullptr; }

 private:
  friend DistributedRun run_pipeline_distributed(const Params&, const PipelineOptions&, Comm&);
  friend void write_distributed(const std::string&, const DistributedRun&, const ExportOptions&,
                                Comm&);
  TriMesh part_mesh_;  // this rank's vertices and faces, when not gathered
  std::unique_ptr<detail::MeshPart> part_;
};

/// Runs every stage of `params` across the ranks of `comm`; `opts.outputs` and `opts.preview`
/// decide (stays_distributed()) whether the mesh is gathered. `opts.keep_grid` is refused
/// (InvalidInput): the grid is not gathered. Every rank validates the parameters alike, so bad
/// input throws the same InvalidInput on every rank; the memory estimate is made on rank 0 and
/// its verdict shared (the limit is rank 0's machine's).
/// @throws InvalidInput, TooLarge, Cancelled (on the rank that saw it). Collective.
DistributedRun run_pipeline_distributed(const Params& params, const PipelineOptions& opts,
                                        Comm& comm);

/// Writes the mesh of `run` to `path`: without gathering, every rank writes its byte ranges of
/// the binary PLY or STL file (the bytes write_mesh() writes); a gathered mesh is written by
/// rank 0 with write_mesh(). No file is left when any rank fails; every rank throws the same
/// error. Collective.
void write_distributed(const std::string& path, const DistributedRun& run,
                       const ExportOptions& opts, Comm& comm);

}  // namespace qjulia
