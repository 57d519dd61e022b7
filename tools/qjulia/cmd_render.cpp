// Placeholder until the render command lands.
#include <stdexcept>

#include "commands.h"

namespace qjulia::cli {
int cmd_render(const Tokens&) { throw std::runtime_error("'render' is not built yet"); }
}  // namespace qjulia::cli
