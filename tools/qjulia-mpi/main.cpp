// qjulia-mpi: `qjulia mesh` across the processes of an MPI run. Usage:
//   mpirun -n K qjulia-mpi mesh [PARAMS.json] [options] -o OUT
// Every rank parses the same arguments and finds the same errors (exit 2, printed once, by
// rank 0); the mesh, the stats and every other file are those of `qjulia mesh`.
#include <mpi.h>

#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <new>
#include <string>
#include <vector>

#include "malloc_setup.h"
#include "mesh_command.h"
#include "mpi_comm.h"
#include "progress_bar.h"
#include "qjulia/base/error.h"
#include "qjulia/base/memory.h"
#include "qjulia/io/mesh_io.h"
#include "qjulia/pipeline/distributed.h"
#include "signals.h"

namespace {

constexpr const char* kUsage = R"(usage: mpirun -n K qjulia-mpi mesh [PARAMS.json] [options] -o OUT
       qjulia-mpi version

Meshes a quaternionic Julia set across K processes: the options and the files are those of
'qjulia mesh' (qjulia-mpi mesh --help lists them). Binary PLY and STL are written by every rank
at its part of the file; other formats, --faces, --max-error, --size, --min-thickness, --check
and --preview gather the mesh to rank 0 first. --vdb is not available (exit 2).
)";

int run(int argc, char** argv, qjulia::mpi::MpiComm& comm) {
  using namespace qjulia;
  using namespace qjulia::cli;
  const bool root = comm.rank() == 0;
  if (argc >= 2 && (std::string(argv[1]) == "version" || std::string(argv[1]) == "--version")) {
    if (argc > 2) {
      if (root) std::fprintf(stderr, "qjulia-mpi version: takes no arguments, not '%s'\n", argv[2]);
      return 2;
    }
    if (root) std::printf("qjulia-mpi %s\n", qjulia::version());
    return 0;
  }
  if (argc < 2 || std::string(argv[1]) != "mesh") {
    if (root) std::fputs(kUsage, stderr);
    return 2;
  }
  const CancelToken& cancel = interrupt_token();
  const std::vector<std::string> tokens(argv + 2, argv + argc);
  // Only rank 0 prints: help, progress, the summary.
  std::unique_ptr<MeshCommand> cmd;
  if (root) {
    cmd = parse_mesh_command(tokens, cancel, "mpirun -n K qjulia-mpi mesh");
    if (!cmd) return 0;
  } else {
    std::FILE* quiet = std::freopen("/dev/null", "w", stdout);
    (void)quiet;
    cmd = parse_mesh_command(tokens, cancel, "qjulia-mpi mesh");
    if (!cmd) return 0;
    cmd->written.commit();  // rank 0 owns the outputs
  }
  ProgressBar bar(!root || cmd->args.has("quiet"));
  PipelineOptions popts = cmd->pipeline;
  if (root) popts.progress = bar.callback();
  DistributedRun run = run_pipeline_distributed(cmd->params, popts, comm);
  RunStats& stats = run.result.stats;
  if (comm.sum(stats.measure.faces) == 0)  // rank 0's measures are the whole mesh's
    throw InvalidInput(cli::nothing_written(cmd->params, stats));
  ExportOptions eopts;
  eopts.params_json = cmd->params_json;
  eopts.unit = stats.unit;
  if (root)
    eopts.progress = [&bar](double f) {
      bar.update("write", f);
      return true;
    };
  write_distributed(cmd->out, run, eopts, comm);
  bar.finish();
  if (!root) return 0;
  finish_mesh_command(*cmd, stats, run.gathered() ? &run.result.mesh : nullptr, cancel);
  double busy_max = 0, busy_sum = 0;
  for (std::size_t r = 0; r < stats.ranks.size(); ++r) {
    const RunStats::Rank& k = stats.ranks[r];
    std::printf("rank %zu: %llu bricks, %llu evaluations, %.2f s (%.2f s busy), %s sent\n", r,
                static_cast<unsigned long long>(k.bricks),
                static_cast<unsigned long long>(k.evaluations), k.seconds, k.busy_seconds,
                format_bytes(static_cast<double>(k.bytes_sent)).c_str());
    busy_max = std::max(busy_max, k.busy_seconds);
    busy_sum += k.busy_seconds;
  }
  std::printf("%zu ranks, load imbalance %.2f (slowest rank's work / mean)%s\n", stats.ranks.size(),
              busy_sum > 0 ? busy_max * stats.ranks.size() / busy_sum : 1.0,
              stats.gathered ? ", mesh gathered to rank 0" : "");
  return 0;
}

}  // namespace

// `qjulia-mpi mesh` restarts once with malloc on huge pages, as `qjulia mesh` does (before the
// libraries' initialisers and MPI_Init; the process keeps its pid, arguments and environment).
__attribute__((section(".preinit_array"),
               used)) static void (*kRestartEarly)(int, char**,
                                                   char**) = &qjulia::cli::restart_early;

int main(int argc, char** argv) {
  // malloc as in `qjulia mesh`: blocks up to 32 MiB from the heap, which keeps its free top, and
  // a worker thread's heap made whole at once (see malloc_setup.h).
  qjulia::cli::fix_malloc_thresholds();
  int provided = 0;
  MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided);
  qjulia::cli::install_signal_handlers();
  int code = 0;
  {
    qjulia::mpi::MpiComm comm(MPI_COMM_WORLD);
    const bool root = comm.rank() == 0;
    try {
      code = run(argc, argv, comm);
    } catch (const qjulia::InvalidInput& e) {
      // Every rank found it alike (the arguments, the estimate's verdict and the write
      // errors are agreed): rank 0 prints it, all exit 2.
      if (root) std::fprintf(stderr, "qjulia-mpi mesh: %s\n", e.what());
      code = 2;
    } catch (const qjulia::Cancelled&) {
      // This rank stopped; the others may be waiting for it in a collective step.
      const int signal = qjulia::cli::interrupting_signal();
      std::fprintf(stderr, "qjulia-mpi mesh: rank %d interrupted%s; nothing written\n", comm.rank(),
                   signal == SIGINT ? " by SIGINT"
                   : signal         ? " by SIGTERM"
                                    : "");
      MPI_Abort(MPI_COMM_WORLD, signal ? qjulia::cli::exit_code_for_signal(signal) : 1);
    } catch (const std::bad_alloc&) {
      // This rank alone: the others may be waiting for it in a collective step.
      std::fprintf(stderr, "qjulia-mpi mesh: error on rank %d: out of memory (peak %s resident)\n",
                   comm.rank(),
                   qjulia::format_bytes(static_cast<double>(qjulia::peak_rss_bytes())).c_str());
      MPI_Abort(MPI_COMM_WORLD, 1);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "qjulia-mpi mesh: error on rank %d: %s\n", comm.rank(), e.what());
      MPI_Abort(MPI_COMM_WORLD, 1);
    }
  }
  MPI_Finalize();
  return code;
}
