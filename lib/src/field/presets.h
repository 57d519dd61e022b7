#pragma once
#include <utility>
#include <vector>

namespace qjulia::detail {
/// (name, JSON text) of every preset in data/presets, in CMake's order.
const std::vector<std::pair<const char*, const char*>>& embedded_presets();
}  // namespace qjulia::detail
