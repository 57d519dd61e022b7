// Placeholder until the experiment command lands.
#include <stdexcept>

#include "commands.h"

namespace qjulia::cli {
int cmd_experiment(const Tokens&) { throw std::runtime_error("'experiment' is not built yet"); }
}  // namespace qjulia::cli
