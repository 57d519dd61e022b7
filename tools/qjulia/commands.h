#pragma once
// The subcommands of `qjulia`. Each returns the process exit code and may throw InvalidInput
// (exit 2), Cancelled (exit 130 / 143 after a signal) or another std::exception (exit 1);
// main() turns those into one line on stderr. `cancel` goes to every stage a command runs.
#include <string>
#include <vector>

#include "qjulia/base/progress.h"

namespace qjulia::cli {

using Tokens = std::vector<std::string>;

int cmd_mesh(const Tokens& args, const CancelToken& cancel);
int cmd_presets(const Tokens& args);
int cmd_params(const Tokens& args);
int cmd_bench(const Tokens& args, const CancelToken& cancel);
int cmd_compare(const Tokens& args, const CancelToken& cancel);
int cmd_experiment(const Tokens& args, const CancelToken& cancel);
int cmd_render(const Tokens& args, const CancelToken& cancel);
int cmd_explore(const Tokens& args, const CancelToken& cancel);

}  // namespace qjulia::cli
