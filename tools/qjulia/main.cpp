// qjulia: meshes of quaternionic Julia sets. Dispatches to the subcommands.
#include <csignal>
#include <cstdio>
#include <exception>
#include <new>
#include <string>
#include <vector>

#include "commands.h"
#include "malloc_setup.h"
#include "qjulia/base/error.h"
#include "qjulia/base/memory.h"
#include "qjulia/pipeline/pipeline.h"
#include "signals.h"

namespace {

constexpr const char* kUsage = R"(usage: qjulia COMMAND [ARGS]

commands:
  mesh [PARAMS.json|MESH] [opts] -o OUT mesh a Julia set (default: the Newton cubic, cut-off)
  presets                               list the built-in presets
  params --preset NAME                  print a preset as a parameter file
  compare A B [options]                 compare two surfaces (meshes or parameter sets)
  render MESH -o OUT.png [options]      draw a preview image
  experiment NAME [options]             reproduce an experiment (table1, cardioid)
  bench [options]                       measure the pipeline's speed
  explore [PARAMS.json] [options]       the interactive page in the browser
  version                               print the version

'qjulia COMMAND --help' (or 'qjulia help COMMAND') describes a command's options.
)";

/// `text` as one line: control characters (bytes of a hostile file quoted in a message, a
/// newline or an escape sequence among them) are written as \xNN, so an error stays one line
/// and cannot drive the terminal.
std::string one_line(const char* text) {
  std::string out;
  for (const char* p = text; *p; ++p) {
    const auto c = static_cast<unsigned char>(*p);
    if (c < 0x20 || c == 0x7f) {
      char escaped[5];
      std::snprintf(escaped, sizeof escaped, "\\x%02x", c);
      out += escaped;
    } else {
      out += *p;
    }
  }
  return out;
}

/// Runs `command` with its arguments; 2 for an unknown command.
int run(const std::string& command, const qjulia::cli::Tokens& args,
        const qjulia::CancelToken& cancel) {
  using namespace qjulia::cli;
  if (command == "mesh") return cmd_mesh(args, cancel);
  if (command == "presets") return cmd_presets(args);
  if (command == "params") return cmd_params(args);
  if (command == "compare") return cmd_compare(args, cancel);
  if (command == "render") return cmd_render(args, cancel);
  if (command == "experiment") return cmd_experiment(args, cancel);
  if (command == "bench") return cmd_bench(args, cancel);
  if (command == "explore") return cmd_explore(args, cancel);
  if (command == "version" || command == "--version") {
    if (!args.empty()) throw qjulia::InvalidInput("takes no arguments, not '" + args[0] + "'");
    std::printf("qjulia %s\n", qjulia::version());
    return 0;
  }
  if (command == "help" || command == "--help" || command == "-h") {
    // `qjulia help mesh` is `qjulia mesh --help`.
    if (args.size() == 1 && args[0] != "help" && args[0] != "version")
      return run(args[0], {"--help"}, cancel);
    if (!args.empty())
      throw qjulia::InvalidInput("'" + args[0] +
                                 "' is not a command with options (try 'qjulia help')");
    std::fputs(kUsage, stdout);
    return 0;
  }
  std::fprintf(stderr, "qjulia: unknown command '%s' (try 'qjulia help')\n", command.c_str());
  return 2;
}

}  // namespace

// Commands that do real work restart once with malloc on huge pages (classic-julia at 256 on
// one thread: 0.28 s instead of 0.40), before the libraries' initialisers run.
__attribute__((section(".preinit_array"),
               used)) static void (*kRestartEarly)(int, char**,
                                                   char**) = &qjulia::cli::restart_early;

int main(int argc, char** argv) {
  using namespace qjulia::cli;
  // Blocks up to 32 MiB from the heap, which keeps its free top up to 128 MiB: a run's passes
  // reuse its pages instead of faulting in fresh ones (classic-julia at 256 on one thread: 0.29 s
  // instead of 0.36); a worker thread's heap made whole at once, not page by page.
  fix_malloc_thresholds();
  install_signal_handlers();
  const qjulia::CancelToken& cancel = interrupt_token();
  if (argc < 2) {
    std::fputs(kUsage, stderr);
    return 2;
  }
  const std::string command = argv[1];
  const Tokens args(argv + 2, argv + argc);
  try {
    return run(command, args, cancel);
  } catch (const qjulia::InvalidInput& e) {
    std::fprintf(stderr, "qjulia %s: %s\n", command.c_str(), one_line(e.what()).c_str());
    return 2;
  } catch (const qjulia::Cancelled&) {
    // Everything the command wrote is removed by now (its OutputFiles and AtomicFiles unwound).
    if (const int signal = interrupting_signal()) {
      std::fprintf(stderr, "qjulia %s: interrupted by %s; nothing written\n", command.c_str(),
                   signal == SIGINT ? "SIGINT" : "SIGTERM");
      return exit_code_for_signal(signal);
    }
    std::fprintf(stderr, "qjulia %s: cancelled\n", command.c_str());
    return 1;
  } catch (const std::bad_alloc&) {
    // Outside a run's stages (which name theirs, as a TooLarge above): what was written is
    // removed by now, as for any error.
    std::fprintf(stderr, "qjulia %s: out of memory (peak %s resident); nothing written\n",
                 command.c_str(),
                 qjulia::format_bytes(static_cast<double>(qjulia::peak_rss_bytes())).c_str());
    return 2;
  } catch (const std::exception& e) {
    // As above: what the command wrote is removed by now.
    std::fprintf(stderr, "qjulia %s: error: %s; nothing written\n", command.c_str(),
                 one_line(e.what()).c_str());
    return 1;
  }
}
