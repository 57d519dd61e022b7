// Placeholder until the compare command lands.
#include <stdexcept>

#include "commands.h"

namespace qjulia::cli {
int cmd_compare(const Tokens&) { throw std::runtime_error("'compare' is not built yet"); }
}  // namespace qjulia::cli
