#include "files.h"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <stdexcept>

namespace qjulia::cli {

void write_file_atomic(const std::string& path, const std::string& text) {
  const std::string tmp = path + ".part";
  std::FILE* f = std::fopen(tmp.c_str(), "wb");
  if (!f) throw std::runtime_error(path + ": cannot write: " + std::strerror(errno));
  const bool ok = std::fwrite(text.data(), 1, text.size(), f) == text.size();
  if (std::fclose(f) != 0 || !ok || std::rename(tmp.c_str(), path.c_str()) != 0) {
    const int err = errno;
    std::remove(tmp.c_str());
    throw std::runtime_error(path + ": cannot write: " + std::strerror(err));
  }
}

OutputFiles::~OutputFiles() {
  for (const auto& p : paths_) std::remove(p.c_str());
}

}  // namespace qjulia::cli
