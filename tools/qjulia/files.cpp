#include "files.h"

#include <sys/stat.h>

#include <cstdio>
#include <filesystem>

#include "qjulia/base/atomic_file.h"
#include "qjulia/base/error.h"
#include "qjulia/io/mesh_io.h"

namespace qjulia::cli {

void write_file_atomic(const std::string& path, const std::string& text) {
  AtomicFile file(path);
  file.write(text);
  file.commit();
}

OutputFiles::~OutputFiles() {
  for (const auto& p : written_) std::remove(p.c_str());
}

OutputFiles::Identity OutputFiles::identify(const std::string& path) {
  Identity id;
  id.path = path;
  std::error_code ec;
  id.normal = std::filesystem::absolute(path, ec).lexically_normal().string();
  struct stat st;
  if (::stat(path.c_str(), &st) == 0) {
    id.exists = true;
    id.dev = st.st_dev;
    id.ino = st.st_ino;
  }
  return id;
}

bool OutputFiles::same(const Identity& a, const Identity& b) {
  if (a.exists && b.exists) return a.dev == b.dev && a.ino == b.ino;
  return a.normal == b.normal;
}

void OutputFiles::add_input(const std::string& path) { inputs_.push_back(identify(path)); }

void OutputFiles::add_mesh_input(const std::string& path) {
  add_input(path);
  try {
    for (const auto& f : output_files(path)) add_input(f);
  } catch (const InvalidInput&) {
    // not a mesh extension (a .png cell, a parameter file): the path alone
  }
}

void OutputFiles::claim(const std::string& path) {
  const Identity out = identify(path);
  for (const auto& in : inputs_)
    if (same(in, out)) {
      throw InvalidInput(path + ": is also an input (" + in.path +
                         "); an output never replaces an input");
    }
  for (const auto& c : claimed_)
    if (same(c, out)) throw InvalidInput(path + ": named twice as an output (" + c.path + ")");
  check_output_path(path);
  claimed_.push_back(out);
}

}  // namespace qjulia::cli
