#pragma once
// lib3mf's part of qjulia, in a module of its own (libqjulia_3mf.so) that is loaded on first
// use. lib3mf and what it brings (libzip, OpenSSL's libcrypto, bzip2, zlib, libuuid) took about
// 5 ms of every process's start, twice for the commands that restart themselves (mesh, compare,
// render, ...), while only 3MF files use them. The interface holds no lib3mf or libzip type and
// throws nothing: each call answers "" or why it failed.
#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace qjulia::detail {

/// What a 3MF file is made of: one mesh object, its build item, the unit and the metadata.
struct ThreeMfWrite {
  const std::array<float, 3>* positions = nullptr;
  std::size_t vertices = 0;
  const std::array<std::uint32_t, 3>* triangles = nullptr;
  std::size_t faces = 0;
  std::string unit;       ///< "um", "mm", "cm", "in", "ft", "m"; anything else is millimetres
  std::string generator;  ///< the "Application" metadata
  std::string params;     ///< the "Description" metadata; "" for none
  std::string uuid[3];    ///< of the object, the build and the build item
  /// Asked by the writer as it goes; false stops it (null: never stops).
  bool (*keep_going)(void* token) = nullptr;
  void* token = nullptr;
};

/// The module's entry points (kThreeMfApiVersion guards against a module built for another
/// version of this interface).
constexpr int kThreeMfApiVersion = 1;
struct ThreeMfApi {
  int version = kThreeMfApiVersion;
  /// The 3MF file of `in`, into `bytes`. "" or what failed ("writing: ...").
  std::string (*write)(const ThreeMfWrite& in, std::string& bytes) = nullptr;
  /// Decompresses every entry of the zip archive in `bytes` with libzip, counting (zip headers
  /// may understate sizes), and scans the XML for what overflows lib3mf's reader. "" and the
  /// total in `total`, or why the file is refused: not a zip archive, more than 100 times its
  /// size decompressed (a zip bomb; at least 1 MiB is allowed), a part lib3mf cannot read
  /// safely.
  std::string (*scan)(std::string_view bytes, std::size_t& total) = nullptr;
  /// Parses a 3MF (after scan()) into a model that close() releases; null and `error` when
  /// lib3mf cannot read it.
  void* (*open)(std::string_view bytes, std::string& error) = nullptr;
  void (*close)(void* model) = nullptr;
  /// The vertex and triangle counts of the model's mesh objects, in order.
  std::string (*sizes)(void* model, std::vector<std::array<std::size_t, 2>>& out) = nullptr;
  /// The vertices and triangles of every mesh object, one object after another (an object's
  /// indices offset by the vertices before it), into arrays of the totals of sizes().
  std::string (*mesh)(void* model, std::array<float, 3>* positions,
                      std::array<std::uint32_t, 3>* triangles) = nullptr;
  /// The "Description" metadata, or "" when the model has none.
  std::string (*description)(void* model, std::string& value) = nullptr;
};

/// The entry points, the module loaded on the first call: from $QJULIA_3MF_MODULE if set, else
/// beside the program or module that calls (and its ../lib/qjulia), else where this build and
/// its installation put it. @throws std::runtime_error naming the paths tried.
const ThreeMfApi& threemf_api();

}  // namespace qjulia::detail

/// The module's one exported symbol.
extern "C" const qjulia::detail::ThreeMfApi* qjulia_3mf_api();
