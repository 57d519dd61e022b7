// qjulia explore: the interactive page in the browser, served by a web server inside the binary
// (docs/explore.md).
#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <system_error>
#include <thread>

#include "cli.h"
#include "commands.h"
#include "explore/server.h"
#include "qjulia/base/error.h"
#include "qjulia/base/memory.h"

extern char** environ;

namespace qjulia::cli {
namespace {

constexpr const char* kHelp =
    R"help(usage: qjulia explore [PARAMS.json | --preset NAME] [--port P] [--no-browser] [--listen ADDR]

Serves the interactive page on http://127.0.0.1:P/ and opens it in the browser: every
parameter of qjulia mesh with a live preview, the escape and cut-off methods side by side with
their Hausdorff distance, export in every format. Ctrl-C stops the server.

options:
  PARAMS.json, --preset NAME the parameter set the page starts with (default: newton-cubic);
                             the parameter flags of qjulia mesh override it
  --port P                   the port, 0..65535 (default 8765; 0: any free port)
  --no-browser               only print the address
  --listen ADDR              listen on ADDR instead of 127.0.0.1 (e.g. the machine's LAN
                             address); the server then also answers to the host ADDR:P.
                             Anyone who reaches ADDR can use the server
  --threads T                worker threads of every job, 1..1024 (default: all cores)
  --max-memory SIZE          the memory of all jobs together, e.g. 4G (K, M, G, T = 2^10..
                             2^40 bytes; at least 1M; default: half of what the system has
                             free); a quarter goes to previews, the rest to an export
)help";

constexpr ValueRange kPortRange{0, 65535};
constexpr int kDefaultPort = 8765;

// The server's private directory for the files it writes, removed with everything in it.
class WorkDir {
 public:
  WorkDir() {
    const char* tmp = std::getenv("TMPDIR");
    std::string pattern = std::string(tmp && *tmp ? tmp : "/tmp") + "/qjulia-explore-XXXXXX";
    if (!mkdtemp(pattern.data()))
      throw std::runtime_error("cannot create a directory in " +
                               pattern.substr(0, pattern.rfind('/')));
    path_ = pattern;
  }
  ~WorkDir() {
    std::error_code ignored;
    std::filesystem::remove_all(path_, ignored);
  }
  WorkDir(const WorkDir&) = delete;
  WorkDir& operator=(const WorkDir&) = delete;
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

// Opens `url` with xdg-open, without waiting for it; false when it cannot be started.
bool open_in_browser(const std::string& url) {
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_addopen(&actions, 2, "/dev/null", O_WRONLY, 0);
  std::string program = "xdg-open";
  char* argv[] = {program.data(), const_cast<char*>(url.c_str()), nullptr};
  pid_t pid = 0;
  const int rc = posix_spawnp(&pid, program.c_str(), &actions, nullptr, argv, environ);
  posix_spawn_file_actions_destroy(&actions);
  if (rc != 0) return false;
  std::thread([pid] { waitpid(pid, nullptr, 0); }).detach();  // no zombie left
  return true;
}

}  // namespace

int cmd_explore(const Tokens& tokens, const CancelToken& cancel) {
  auto specs = param_option_specs();
  for (const char* name : {"port", "listen", "threads", "max-memory"}) specs.push_back({name});
  for (const char* name : {"no-browser", "help"}) specs.push_back({name, false});
  const ParsedArgs args = parse_args(tokens, specs, "explore");
  if (args.has("help")) {
    std::fputs(kHelp, stdout);
    return 0;
  }
  if (args.positional.size() > 1)
    throw InvalidInput("expected at most one parameter file, got '" + args.positional[1] + "'");
  const std::string file = args.positional.empty() ? "" : args.positional[0];

  explore::ServerOptions options;
  options.api.initial = params_from_args(args, file);
  options.api.initial_name = !file.empty()        ? std::filesystem::path(file).filename().string()
                             : args.get("preset") ? *args.get("preset")
                                                  : "newton-cubic";
  options.port = kDefaultPort;
  if (const auto port = args.get("port"))
    options.port = static_cast<int>(parse_int(*port, "--port", kPortRange));
  if (const auto listen = args.get("listen")) {
    if (listen->empty()) throw InvalidInput("--listen needs an address, e.g. 192.168.1.10");
    options.listen_address = *listen;
  }
  const ThreadLimit threads(args);
  // One budget for the whole server: previews and one export at a time share it, so no number
  // of requests can take more.
  const auto requested = max_memory_from_args(args);
  const std::size_t budget = requested ? *requested : memory_limits().effective() / 2;
  options.api.preview_memory = budget / 4;
  options.api.export_memory = budget - options.api.preview_memory;
  const WorkDir work_dir;
  options.api.work_dir = work_dir.path();

  const bool browser = !args.has("no-browser");
  explore::serve(options, cancel, [&](const std::string& url) {
    std::printf("qjulia explore: serving %s (Ctrl-C stops the server)\n", url.c_str());
    if (browser && !open_in_browser(url))
      std::printf("qjulia explore: could not start xdg-open; open the address in a browser\n");
    std::fflush(stdout);
  });
  return 0;
}

}  // namespace qjulia::cli
