#include "assets.h"

namespace qjulia::explore {

const std::vector<Asset>& assets() {
  static const std::vector<Asset> all = [] {
    std::vector<Asset> v;
    for (std::size_t i = 0; i < detail::kEmbeddedAssetCount; ++i) {
      const detail::EmbeddedAsset& a = detail::kEmbeddedAssets[i];
      v.push_back({a.path, a.content_type,
                   std::string_view(a.begin, static_cast<std::size_t>(a.end - a.begin))});
    }
    return v;
  }();
  return all;
}

const Asset* find_asset(std::string_view path) {
  for (const Asset& a : assets())
    if (a.path == path) return &a;
  return nullptr;
}

}  // namespace qjulia::explore
