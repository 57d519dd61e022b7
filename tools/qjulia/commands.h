#pragma once
// The subcommands of `qjulia`. Each returns the process exit code and may throw InvalidInput
// (exit 2) or another std::exception (exit 1); main() turns those into one line on stderr.
#include <string>
#include <vector>

namespace qjulia::cli {

using Tokens = std::vector<std::string>;

int cmd_mesh(const Tokens& args);
int cmd_presets(const Tokens& args);
int cmd_params(const Tokens& args);
int cmd_bench(const Tokens& args);
int cmd_compare(const Tokens& args);
int cmd_experiment(const Tokens& args);
int cmd_render(const Tokens& args);

}  // namespace qjulia::cli
