#pragma once
// Output files of the CLI: written whole or not at all.
#include <string>
#include <vector>

namespace qjulia::cli {

/// Writes `text` to `path` through a temporary file renamed at the end.
/// @throws std::runtime_error naming the path when it cannot be written.
void write_file_atomic(const std::string& path, const std::string& text);

/// Remembers the files a command wrote and removes them unless commit() is called, so a
/// command that fails half-way leaves nothing behind.
class OutputFiles {
 public:
  ~OutputFiles();
  void add(const std::string& path) { paths_.push_back(path); }
  void commit() { paths_.clear(); }

 private:
  std::vector<std::string> paths_;
};

}  // namespace qjulia::cli
