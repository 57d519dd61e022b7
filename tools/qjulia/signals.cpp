#include "signals.h"

#include <unistd.h>

#include <atomic>
#include <csignal>

namespace qjulia::cli {
namespace {

CancelToken g_token;
std::atomic<int> g_signal{0};
static_assert(std::atomic<int>::is_always_lock_free, "the handler must be able to set it");

extern "C" void on_signal(int signal) {
  int none = 0;
  if (!g_signal.compare_exchange_strong(none, signal)) _exit(exit_code_for_signal(signal));
  g_token.request();  // async-signal-safe: a lock-free atomic store
}

}  // namespace

void install_signal_handlers() {
  struct sigaction action {};
  action.sa_handler = on_signal;
  sigemptyset(&action.sa_mask);
  action.sa_flags = SA_RESTART;  // system calls go on; the stages see the token
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
  struct sigaction ignore {};
  ignore.sa_handler = SIG_IGN;
  sigemptyset(&ignore.sa_mask);
  sigaction(SIGXFSZ, &ignore, nullptr);
}

const CancelToken& interrupt_token() { return g_token; }

int interrupting_signal() { return g_signal.load(); }

int exit_code_for_signal(int signal) { return 128 + signal; }

}  // namespace qjulia::cli
