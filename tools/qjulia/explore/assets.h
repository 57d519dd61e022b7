#pragma once
// The page of `qjulia explore` and the scripts it loads, embedded into the executable at build
// time (CMakeLists.txt beside this file), so the server reads no file to answer GET requests.
#include <cstddef>
#include <string_view>
#include <vector>

namespace qjulia::explore {

/// One file the server answers a GET request with.
struct Asset {
  std::string_view path;          ///< URL path: "/", "/src/main.js", "/vendor/three/..."
  std::string_view content_type;  ///< e.g. "text/javascript; charset=utf-8"
  std::string_view data;          ///< the file's bytes
};

/// The embedded file at URL path `path` (no query string), or nullptr.
const Asset* find_asset(std::string_view path);

/// Every embedded file, in the order of the build's list.
const std::vector<Asset>& assets();

namespace detail {
/// What the generated asset_data.cpp defines: [begin, end) are a file's bytes.
struct EmbeddedAsset {
  const char* path;
  const char* content_type;
  const char* begin;
  const char* end;
};
extern const EmbeddedAsset kEmbeddedAssets[];
extern const std::size_t kEmbeddedAssetCount;
}  // namespace detail

}  // namespace qjulia::explore
