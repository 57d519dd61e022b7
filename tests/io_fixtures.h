#pragma once
// Helpers of the tests that write files (io, io_fault, export, compare, render): a temporary
// directory, files as bytes, a tmpfs mount of a given size (the tests run as root), and the CLI run
// in a shell.
#include <gtest/gtest.h>
#include <sys/mount.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace io_fixtures {

namespace fs = std::filesystem;

/// The extension of every mesh format the library writes.
inline const std::vector<std::string> kExtensions = {".glb", ".gltf", ".obj",
                                                     ".ply", ".stl",  ".3mf"};

inline std::string read_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

inline std::string write_bytes(const fs::path& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary) << bytes;
  return path.string();
}

/// A fresh directory, removed with everything in it.
class TempDir {
 public:
  explicit TempDir(const std::string& tag = "io") {
    static int counter = 0;
    path_ = fs::temp_directory_path() /
            ("qjulia_" + tag + "_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  std::string file(const std::string& name) const { return (path_ / name).string(); }
  const fs::path& path() const { return path_; }
  /// The names in the directory, sorted (temporary files included: they start with '.').
  std::vector<std::string> names() const {
    std::vector<std::string> out;
    for (const auto& e : fs::directory_iterator(path_)) out.push_back(e.path().filename());
    std::sort(out.begin(), out.end());
    return out;
  }

 private:
  fs::path path_;
};

/// A tmpfs of `size` (mount(8) syntax: "64k") mounted on a fresh directory; unmounted at the
/// end. Mounting needs root, which the tests have: a failure fails the test, it never skips.
/// `type` "ramfs" mounts a ramfs instead (no size limit; it refuses O_DIRECT).
class Tmpfs {
 public:
  explicit Tmpfs(const std::string& size, const std::string& type = "tmpfs") : dir_("tmpfs") {
    const std::string options = "size=" + size + ",mode=0755";
    if (::mount(type.c_str(), dir_.path().c_str(), type.c_str(), 0, options.c_str()) != 0) {
      ADD_FAILURE() << "cannot mount a " << type << " on " << dir_.path() << ": "
                    << std::strerror(errno) << " (the io fault tests run as root)";
    } else {
      mounted_ = true;
    }
  }
  ~Tmpfs() {
    if (mounted_) ::umount2(dir_.path().c_str(), MNT_DETACH);
  }
  bool mounted() const { return mounted_; }
  /// Makes the file system read-only (what it holds stays readable).
  bool remount_read_only() {
    if (::mount("tmpfs", dir_.path().c_str(), "tmpfs", MS_REMOUNT | MS_RDONLY, nullptr) != 0) {
      ADD_FAILURE() << "cannot remount " << dir_.path() << " read-only: " << std::strerror(errno);
      return false;
    }
    return true;
  }
  const TempDir& dir() const { return dir_; }
  std::string file(const std::string& name) const { return dir_.file(name); }

 private:
  TempDir dir_;
  bool mounted_ = false;
};

struct Run {
  int code = -1;
  std::string out;  ///< stdout and stderr
};

/// Runs `command` with /bin/sh; returns its exit code (128 + N when killed by signal N).
inline Run shell(const std::string& command) {
  Run r;
  FILE* pipe = ::popen((command + " 2>&1").c_str(), "r");
  if (!pipe) {
    ADD_FAILURE() << "popen failed: " << command;
    return r;
  }
  char buf[4096];
  std::size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, pipe)) > 0) r.out.append(buf, n);
  const int status = ::pclose(pipe);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  return r;
}

/// The CLI with `args` (already quoted as the shell needs).
inline Run qjulia(const std::string& args) { return shell(std::string(QJULIA_CLI) + " " + args); }

inline std::string quote(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

}  // namespace io_fixtures
