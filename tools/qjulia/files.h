#pragma once
// Input and output files of the CLI: outputs are written whole or not at all, never onto an
// input, a directory, a device or a FIFO.
#include <sys/types.h>

#include <string>
#include <utility>
#include <vector>

namespace qjulia::cli {

/// Writes `text` to `path` through AtomicFile (a temporary file renamed at the end).
/// @throws InvalidInput naming the path when it may not be written (check_output_path);
///         std::runtime_error when writing fails.
void write_file_atomic(const std::string& path, const std::string& text);

/// The files of one command: the inputs it reads and the outputs it will write. Outputs are
/// checked when they are claimed, before any work, and removed again unless commit() is
/// called, so a command that fails half-way leaves nothing behind.
class OutputFiles {
 public:
  ~OutputFiles();
  /// Registers a file the command reads (missing files are ignored: reading reports them).
  void add_input(const std::string& path);
  /// add_input() of a mesh file, and for a .gltf also the .bin of the same name.
  void add_mesh_input(const std::string& path);
  /// Checks that `path` may be written: not one of the inputs (also through a link or another
  /// name), not claimed twice, and check_output_path().
  /// @throws InvalidInput naming the path.
  void claim(const std::string& path);
  /// Remembers a file the command wrote, to remove it unless commit() is called.
  void add(const std::string& path) { written_.push_back(path); }
  void commit() { written_.clear(); }

 private:
  struct Identity {
    std::string path;    ///< as given
    std::string normal;  ///< absolute and lexically normal
    bool exists = false;
    dev_t dev = 0;
    ino_t ino = 0;
  };
  static Identity identify(const std::string& path);
  static bool same(const Identity& a, const Identity& b);
  std::vector<Identity> inputs_;
  std::vector<Identity> claimed_;
  std::vector<std::string> written_;
};

}  // namespace qjulia::cli
