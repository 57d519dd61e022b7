#pragma once
// SIGINT and SIGTERM: the CLI's one cancellation token (and SIGXFSZ, ignored). The library installs
// no handlers; this file is the only place that does.
#include "qjulia/base/progress.h"

namespace qjulia::cli {

/// Installs handlers for SIGINT and SIGTERM. The first of them requests interrupt_token(), so
/// the running stage stops at its next check and the command unwinds, removing what it wrote;
/// a second one ends the process at once with exit code 128 + signal. SIGXFSZ is ignored, so a
/// file-size limit (ulimit -f) makes the write fail with EFBIG: the command then exits with
/// an error naming the file and removes its temporary file, instead of dying half-way.
void install_signal_handlers();

/// The token the handlers request; every stage of a command gets it.
const CancelToken& interrupt_token();

/// The signal that requested the token (SIGINT or SIGTERM), 0 when none came.
int interrupting_signal();

/// The exit code of a command interrupted by `signal`: 128 + signal (130 for SIGINT, 143 for
/// SIGTERM).
int exit_code_for_signal(int signal);

}  // namespace qjulia::cli
