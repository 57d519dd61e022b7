// File-system faults and outputs that point elsewhere: a full disk, a file-size limit, a
// read-only directory, outputs that are directories, devices, FIFOs or one of the inputs; in
// the library (AtomicFile, write_mesh) and end to end through the CLI. The tests run as root
// and mount small tmpfs file systems; when mounting fails they fail.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/stat.h>

#include <atomic>
#include <cmath>
#include <cstring>
#include <random>
#include <string_view>

#include "io_fixtures.h"
#include "qjulia/base/atomic_file.h"
#include "qjulia/base/error.h"
#include "qjulia/io/mesh_io.h"
#include "test_meshes.h"

namespace {

using io_fixtures::qjulia;
using io_fixtures::quote;
using io_fixtures::read_bytes;
using io_fixtures::TempDir;
using io_fixtures::Tmpfs;
using io_fixtures::write_bytes;
using qjulia::InvalidInput;
namespace fs = std::filesystem;

using io_fixtures::kExtensions;

bool has(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

// ------------------------------------------------------------------------ AtomicFile

TEST(AtomicFile, NeverReplacesADirectoryADeviceOrAFifo) {
  TempDir dir;
  fs::create_directory(dir.file("out.ply"));
  ASSERT_EQ(::mkfifo(dir.file("fifo.ply").c_str(), 0644), 0);
  fs::create_symlink("/dev/null", dir.file("null.ply"));
  const std::vector<std::string> names = dir.names();
  for (const std::string& path : {dir.file("out.ply"), dir.file("fifo.ply"), dir.file("null.ply"),
                                  std::string("/dev/null")}) {
    try {
      qjulia::AtomicFile f(path);
      ADD_FAILURE() << "created " << path;
    } catch (const InvalidInput& e) {
      EXPECT_EQ(std::string(e.what()).rfind(path + ": exists and is a ", 0), 0u) << e.what();
      EXPECT_TRUE(has(e.what(), "never replaces")) << e.what();
    }
    if (path != "/dev/null") {
      EXPECT_THROW(qjulia::write_mesh(path, fixtures::icosphere(1)), InvalidInput);
    }
  }
  EXPECT_EQ(dir.names(), names);  // nothing replaced, no temporary file
  EXPECT_TRUE(fs::is_directory(dir.file("out.ply")));
  EXPECT_TRUE(fs::is_fifo(dir.file("fifo.ply")));
  EXPECT_TRUE(fs::is_character_file("/dev/null"));
}

TEST(AtomicFile, TemporaryNamesAreExclusiveAndALinkToAFileIsReplacedNotFollowed) {
  TempDir dir;
  const std::string target = write_bytes(dir.file("target.txt"), "old");
  fs::create_symlink(target, dir.file("link.txt"));
  qjulia::AtomicFile a(dir.file("link.txt")), b(dir.file("link.txt"));
  EXPECT_NE(a.temp_path(), b.temp_path());
  a.write("a");
  b.write("b");
  a.commit();
  b.commit();
  EXPECT_EQ(read_bytes(dir.file("link.txt")), "b");
  EXPECT_FALSE(fs::is_symlink(dir.file("link.txt")));
  EXPECT_EQ(read_bytes(target), "old");
  EXPECT_EQ(dir.names(), (std::vector<std::string>{"link.txt", "target.txt"}));
}

// Bytes of a large file in pieces of odd sizes: the writer stages blocks of kStageBytes, writes
// full ones past the page cache where the file system allows it, and the rest through it.
std::string big_bytes(std::size_t size) {
  std::string s(size, '\0');
  std::mt19937_64 rng(size);
  for (char& c : s) c = static_cast<char>(rng());
  return s;
}

void write_in_pieces(qjulia::AtomicFile& f, const std::string& bytes) {
  std::mt19937 rng(7);
  for (std::size_t at = 0; at < bytes.size();) {
    const std::size_t n = std::min<std::size_t>(bytes.size() - at, 1 + rng() % (5u << 20));
    f.write(bytes.data() + at, n);
    at += n;
  }
}

// A folder on the disk, a tmpfs and a ramfs (which refuses O_DIRECT: every byte through the
// page cache), for the same file in each.
struct ThreeFileSystems {
  TempDir dir;
  Tmpfs disk{"80m"};
  Tmpfs ram{"80m", "ramfs"};
  bool mounted() const { return disk.mounted() && ram.mounted(); }
  std::vector<std::string> files(const std::string& name) const {
    return {dir.file(name), disk.file(name), ram.file(name)};
  }
};

TEST(AtomicFile, ALargeFileHoldsExactlyItsBytesOnDiskATmpfsAndARamfs) {
  const ThreeFileSystems places;
  ASSERT_TRUE(places.mounted());
  // Below one stage, exactly three stages, and twelve stages and a partial one.
  constexpr std::size_t kStage = qjulia::AtomicFile::kStageBytes;
  for (const std::size_t size : {std::size_t(100000), 3 * kStage, 12 * kStage + 12345}) {
    const std::string bytes = big_bytes(size);
    for (const std::string& path : places.files("big.bin")) {
      qjulia::AtomicFile f(path);
      write_in_pieces(f, bytes);
      f.commit();
      EXPECT_TRUE(read_bytes(path) == bytes) << path << ", " << size << " bytes";
      fs::remove(path);
    }
  }
}

// The formatting writer puts its bytes straight into the file's stage: records reserved and
// committed in part, strings longer than the stage, single characters, reservations larger
// than the stage and flushes at any point all land in order.
TEST(AtomicFile, TheFormattingWriterWritesExactlyWhatItIsGiven) {
  TempDir dir;
  Tmpfs ram("80m", "ramfs");
  ASSERT_TRUE(ram.mounted());
  constexpr std::size_t kStage = qjulia::AtomicFile::kStageBytes;
  const std::string source = big_bytes(3 * kStage + 777);
  for (const std::string& path : {dir.file("fmt.bin"), ram.file("fmt.bin")}) {
    std::mt19937 rng(11);
    std::string expected;
    qjulia::AtomicFile f(path);
    qjulia::BufferedWriter out(f);
    auto piece = [&](std::size_t n) {
      return std::string_view(source).substr(rng() % (source.size() - n), n);
    };
    // Records alone first (as the binary writers put them: the stage goes out with a partial
    // block left over each time), then everything mixed.
    while (expected.size() < 9 * kStage) {
      switch (expected.size() < 4 * kStage ? rng() % 3 / 2 * 2 : rng() % 6) {
        case 0: {  // a record, of which only a part is committed
          const std::size_t n = 1 + rng() % 3000, used = rng() % (n + 1);
          const std::string_view p = piece(n);
          std::memcpy(out.reserve(n), p.data(), n);
          out.advance(used);
          expected.append(p.substr(0, used));
          break;
        }
        case 1: {  // a string, now and then up to two and a half stages long
          const std::string_view p = piece(rng() % (rng() % 8 ? 5000 : 5 * kStage / 2));
          out.put(p.data(), p.size());
          expected.append(p);
          break;
        }
        case 2: {
          const char c = static_cast<char>(rng());
          out.put(c);
          expected.push_back(c);
          break;
        }
        case 3: {  // a reservation larger than the stage
          const std::string_view p = piece(kStage + 1 + rng() % 5000);
          std::memcpy(out.reserve(p.size()), p.data(), p.size());
          out.advance(p.size());
          expected.append(p);
          break;
        }
        case 4:
          out.flush();
          break;
        default: {  // a direct write between flushes
          out.flush();
          const std::string_view p = piece(rng() % 100000);
          f.write(p.data(), p.size());
          expected.append(p);
        }
      }
    }
    out.flush();
    f.commit();
    EXPECT_EQ(fs::file_size(path), expected.size()) << path;
    EXPECT_TRUE(read_bytes(path) == expected) << path;
    fs::remove(path);
  }
}

// A stage is written out while the next is filled: a file given up (no commit) with a block
// still being written, or cancelled there, leaves nothing behind and the old file as it was.
TEST(AtomicFile, AFileGivenUpWithABlockInFlightLeavesNothingAndTheOldFile) {
  TempDir dir;
  const std::string path = dir.file("kept.bin");
  write_bytes(path, "old");
  constexpr std::size_t kStage = qjulia::AtomicFile::kStageBytes;
  for (int round = 0; round < 20; ++round) {
    qjulia::CancelToken cancel;
    {
      qjulia::AtomicFile f(path, &cancel);
      // One stage and a little more: the first stage goes out while the writer goes on.
      write_in_pieces(f, big_bytes(kStage + 1000 + round * 4097));
      if (round % 2) {
        cancel.request();
        EXPECT_THROW(write_in_pieces(f, big_bytes(kStage)), qjulia::Cancelled);
      }
    }
    EXPECT_EQ(read_bytes(path), "old") << "round " << round;
    EXPECT_EQ(dir.names().size(), 1u) << "round " << round << ": " << dir.names().back();
  }
}

// A region of the file written by threads of its own at its offset, while the owner appends the
// bytes before it: below one block, whole blocks, and blocks with a partial one, after prefixes
// of one and of several stages; the file holds exactly the bytes of both.
TEST(AtomicFile, ARegionWrittenByThreadsOfItsOwnLandsAtItsOffsetOnDiskATmpfsAndARamfs) {
  const ThreeFileSystems places;
  ASSERT_TRUE(places.mounted());
  constexpr std::size_t kStage = qjulia::AtomicFile::kStageBytes;
  constexpr std::size_t kAlign = qjulia::RegionWriter::kAlignment;
  const std::pair<std::size_t, std::size_t> cases[] = {
      {kAlign, 100000}, {3 * kStage, 3 * kStage}, {5 * kAlign, 7 * kStage + 12345}};
  for (const auto& [before, size] : cases) {
    const std::string bytes = big_bytes(before + size);
    for (const std::string& path : places.files("big.bin")) {
      qjulia::AtomicFile f(path);
      std::atomic<std::size_t> filled{0};
      qjulia::RegionWriter region(f, before, size,
                                  [&](char* out, std::uint64_t first, std::size_t n) {
                                    std::memcpy(out, bytes.data() + before + first, n);
                                    filled += n;
                                  });
      write_in_pieces(f, bytes.substr(0, before));
      region.finish();
      f.commit();
      EXPECT_EQ(filled, size);
      EXPECT_TRUE(read_bytes(path) == bytes) << path << ", " << size << " bytes at " << before;
      fs::remove(path);
    }
  }
  TempDir other;
  qjulia::AtomicFile f(other.file("x.bin"));
  EXPECT_THROW(qjulia::RegionWriter(f, kAlign + 1, 10, [](char*, std::uint64_t, std::size_t) {}),
               std::logic_error);
}

// A region given up (its writer destroyed before finish(), as when the owner throws), cancelled,
// or whose bytes cannot be made, leaves nothing behind and the old file as it was.
TEST(AtomicFile, ARegionGivenUpCancelledOrFailingLeavesNothingAndTheOldFile) {
  TempDir dir;
  const std::string path = dir.file("kept.bin");
  write_bytes(path, "old");
  constexpr std::size_t kStage = qjulia::AtomicFile::kStageBytes;
  const std::string bytes = big_bytes(9 * kStage);
  auto copy = [&](char* out, std::uint64_t first, std::size_t n) {
    std::memcpy(out, bytes.data() + first, n);
  };
  for (int round = 0; round < 9; ++round) {
    qjulia::CancelToken cancel;
    try {
      qjulia::AtomicFile f(path, &cancel);
      if (round % 3 == 0) {  // given up
        qjulia::RegionWriter region(f, kStage, bytes.size(), copy);
        write_in_pieces(f, bytes.substr(0, kStage));
      } else if (round % 3 == 1) {  // cancelled while the region goes out
        qjulia::RegionWriter region(f, kStage, bytes.size(), copy);
        cancel.request();
        EXPECT_THROW(region.finish(), qjulia::Cancelled);
      } else {  // the bytes of its fourth block cannot be made
        qjulia::RegionWriter region(f, 0, bytes.size(),
                                    [&](char* out, std::uint64_t first, std::size_t n) {
                                      if (first >= 3 * kStage)
                                        throw std::runtime_error("no bytes there");
                                      copy(out, first, n);
                                    });
        EXPECT_THROW(region.finish(), std::runtime_error);
      }
    } catch (const std::exception& e) {
      ADD_FAILURE() << "round " << round << ": " << e.what();
    }
    EXPECT_EQ(read_bytes(path), "old") << "round " << round;
    EXPECT_EQ(dir.names().size(), 1u) << "round " << round << ": " << dir.names().back();
  }
}

// Through the stages, and as a region written by threads of its own (the whole file, so that
// only they meet the full disk).
TEST(AtomicFile, ADiskThatFillsAfterTheFirstBlocksIsARuntimeErrorAndLeavesNoFile) {
  Tmpfs disk("40m");
  ASSERT_TRUE(disk.mounted());
  const std::string path = disk.file("big.bin");
  const std::string bytes = big_bytes(std::size_t(60) << 20);
  for (const bool region : {false, true}) {
    SCOPED_TRACE(region ? "a region" : "the stages");
    try {
      qjulia::AtomicFile f(path);
      if (region) {
        qjulia::RegionWriter r(f, 0, bytes.size(),
                               [&](char* out, std::uint64_t first, std::size_t n) {
                                 std::memcpy(out, bytes.data() + first, n);
                               });
        r.finish();
      } else {
        write_in_pieces(f, bytes);
      }
      f.commit();
      ADD_FAILURE() << "written: " << path;
    } catch (const InvalidInput& e) {
      ADD_FAILURE() << "a full disk is not bad input: " << e.what();
    } catch (const std::runtime_error& e) {
      EXPECT_EQ(std::string(e.what()), path + ": write failed (No space left on device)");
    }
    EXPECT_TRUE(disk.dir().names().empty()) << disk.dir().names().front();
  }
}

TEST(AtomicFile, AFullDiskIsARuntimeErrorAndLeavesNoTemporaryFile) {
  Tmpfs disk("64k");
  ASSERT_TRUE(disk.mounted());
  const qjulia::TriMesh mesh = fixtures::icosphere(5);  // 20480 faces: over 250 kB in any format
  for (const auto& ext : kExtensions) {
    const std::string path = disk.file("m" + ext);
    try {
      qjulia::write_mesh(path, mesh);
      ADD_FAILURE() << "written: " << path;
    } catch (const InvalidInput& e) {
      ADD_FAILURE() << "a full disk is not bad input: " << e.what();
    } catch (const std::runtime_error& e) {
      // A .gltf writes its .bin first: the message names the file that did not fit.
      const std::string named = ext == ".gltf" ? disk.file("m.bin") : path;
      EXPECT_EQ(std::string(e.what()), named + ": write failed (No space left on device)");
    }
    EXPECT_TRUE(disk.dir().names().empty()) << ext << ": " << disk.dir().names().front();
  }
}

TEST(AtomicFile, AFileSizeLimitIsARuntimeErrorAndLeavesNoTemporaryFile) {
  TempDir dir;
  const qjulia::TriMesh mesh = fixtures::icosphere(4);
  for (const auto& ext : kExtensions) {
    const std::string path = dir.file("m" + ext);
    const pid_t child = ::fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
      // In the child: RLIMIT_FSIZE of 10 kB; SIGXFSZ ignored, so write() fails with EFBIG.
      ::signal(SIGXFSZ, SIG_IGN);
      const rlimit limit{10000, 10000};
      ::setrlimit(RLIMIT_FSIZE, &limit);
      int code = 3;
      try {
        qjulia::write_mesh(path, mesh);
        code = 4;
      } catch (const InvalidInput&) {
        code = 5;
      } catch (const std::runtime_error& e) {
        const std::string named = ext == ".gltf" ? dir.file("m.bin") : path;
        code = std::string(e.what()) == named + ": write failed (File too large)" ? 0 : 6;
      }
      ::_exit(code);
    }
    int status = 0;
    ASSERT_EQ(::waitpid(child, &status, 0), child);
    ASSERT_TRUE(WIFEXITED(status)) << ext;
    EXPECT_EQ(WEXITSTATUS(status), 0) << ext << " (3 other, 4 written, 5 InvalidInput, 6 message)";
    EXPECT_TRUE(dir.names().empty()) << ext << ": " << dir.names().front();
  }
}

TEST(AtomicFile, AReadOnlyDirectoryIsBadInputAndItsFilesStayAsTheyWere) {
  Tmpfs ro("1m");
  ASSERT_TRUE(ro.mounted());
  const std::string old = write_bytes(ro.file("old.ply"), "old bytes");
  ASSERT_TRUE(ro.remount_read_only());
  for (const std::string& path : {ro.file("new.glb"), ro.file("old.ply")}) {
    try {
      qjulia::write_mesh(path, fixtures::icosphere(1));
      ADD_FAILURE() << "written: " << path;
    } catch (const InvalidInput& e) {
      EXPECT_EQ(std::string(e.what()).rfind(path + ": ", 0), 0u) << e.what();
      EXPECT_TRUE(has(e.what(), "Read-only file system")) << e.what();
    }
  }
  EXPECT_EQ(read_bytes(old), "old bytes");
  EXPECT_EQ(ro.dir().names(), std::vector<std::string>{"old.ply"});
}

TEST(AtomicFile, AMissingDirectoryIsBadInput) {
  TempDir dir;
  EXPECT_THROW(qjulia::AtomicFile(dir.file("no/such/dir/x")), InvalidInput);
  EXPECT_THROW(qjulia::check_output_path(""), InvalidInput);
  write_bytes(dir.file("file"), "x");
  EXPECT_THROW(qjulia::AtomicFile(dir.file("file/x")), InvalidInput);  // a file as a folder
}

// ------------------------------------------------------------------------ the CLI

/// A small mesh file made by the CLI's writer.
std::string sphere_file(const TempDir& dir, const std::string& name) {
  const std::string path = dir.file(name);
  qjulia::write_mesh(path, fixtures::icosphere(2));
  return path;
}

void expect_exit(const io_fixtures::Run& r, int code, const std::string& names) {
  EXPECT_EQ(r.code, code) << r.out;
  EXPECT_TRUE(has(r.out, names)) << "the message does not name " << names << ":\n" << r.out;
}

TEST(CliFiles, AnOutputThatIsAnInputExitsTwoAndTheInputStaysAsItWas) {
  TempDir dir;
  const std::string a = sphere_file(dir, "a.ply");
  const std::string b = sphere_file(dir, "b.glb");
  const std::string a_bytes = read_bytes(a);
  fs::create_symlink(a, dir.file("link.ply"));
  fs::create_hard_link(a, dir.file("hard.ply"));
  for (const std::string& out : {a, dir.file("link.ply"), dir.file("hard.ply")}) {
    expect_exit(qjulia("compare " + quote(a) + " " + quote(b) + " --quiet --colored " + quote(out)),
                2, out + ": is also an input");
  }
  expect_exit(qjulia("compare " + quote(a) + " " + quote(b) + " --quiet --json " + quote(b)), 2,
              b + ": is also an input");
  // render -o onto a mesh input (through a link named .png) and onto a .png input.
  fs::create_symlink(a, dir.file("a_as.png"));
  expect_exit(qjulia("render " + quote(a) + " -o " + quote(dir.file("a_as.png"))), 2,
              dir.file("a_as.png") + ": is also an input");
  ASSERT_EQ(qjulia("render " + quote(a) + " -o " + quote(dir.file("cell.png"))).code, 0);
  const std::string cell = read_bytes(dir.file("cell.png"));
  expect_exit(qjulia("render " + quote(dir.file("cell.png")) + " " + quote(b) + " -o " +
                     quote(dir.file("cell.png"))),
              2, dir.file("cell.png") + ": is also an input");
  // mesh: --stats onto the parameter file, two outputs on one file.
  const std::string params = write_bytes(dir.file("p.json"), R"({"resolution": 16})");
  expect_exit(qjulia("mesh " + quote(params) + " --quiet -o " + quote(dir.file("m.glb")) +
                     " --stats " + quote(params)),
              2, params + ": is also an input");
  expect_exit(qjulia("mesh --resolution 16 --quiet -o " + quote(dir.file("m.stl")) + " --stats " +
                     quote(dir.file("m.stl.json"))),
              2, dir.file("m.stl.json") + ": named twice");
  EXPECT_EQ(read_bytes(a), a_bytes);
  EXPECT_EQ(read_bytes(dir.file("cell.png")), cell);
  EXPECT_EQ(read_bytes(params), R"({"resolution": 16})");
  EXPECT_EQ(dir.names(), (std::vector<std::string>{"a.ply", "a_as.png", "b.glb", "cell.png",
                                                   "hard.ply", "link.ply", "p.json"}));
}

TEST(CliFiles, AnOutputThatIsADirectoryADeviceOrAFifoExitsTwoBeforeAnyWork) {
  TempDir dir;
  fs::create_directory(dir.file("dir.glb"));
  ASSERT_EQ(::mkfifo(dir.file("fifo.ply").c_str(), 0644), 0);
  fs::create_symlink("/dev/null", dir.file("null.stl"));
  for (const std::string name : {"dir.glb", "fifo.ply", "null.stl"}) {
    // A resolution that would take minutes: the refusal must come first.
    const io_fixtures::Run r = qjulia("mesh --resolution 2000 --quiet -o " + quote(dir.file(name)));
    expect_exit(r, 2, dir.file(name) + ": exists and is a");
  }
  const std::string a = sphere_file(dir, "a.ply");
  fs::create_symlink("/dev/null", dir.file("null.png"));
  expect_exit(qjulia("render " + quote(a) + " -o " + quote(dir.file("null.png"))), 2,
              dir.file("null.png") + ": exists and is a character device");
  EXPECT_TRUE(fs::is_directory(dir.file("dir.glb")));
  EXPECT_TRUE(fs::is_fifo(dir.file("fifo.ply")));
  EXPECT_EQ(dir.names().size(), 5u);
}

TEST(CliFiles, AReadOnlyDirectoryExitsTwoNamingThePath) {
  Tmpfs ro("1m");
  ASSERT_TRUE(ro.mounted());
  ASSERT_TRUE(ro.remount_read_only());
  const std::string out = ro.file("m.glb");
  expect_exit(qjulia("mesh --resolution 2000 --quiet -o " + quote(out)), 2,
              out + ": cannot write in the directory");
  TempDir dir;
  const std::string a = sphere_file(dir, "a.ply");
  expect_exit(qjulia("render " + quote(a) + " -o " + quote(ro.file("x.png"))), 2, ro.file("x.png"));
  EXPECT_TRUE(ro.dir().names().empty());
}

TEST(CliFiles, AFullDiskExitsOneNamingThePathAndLeavesNothing) {
  Tmpfs disk("64k");
  ASSERT_TRUE(disk.mounted());
  const std::string out = disk.file("m.ply");
  expect_exit(qjulia("mesh --resolution 48 --quiet -o " + quote(out)), 1,
              out + ": write failed (No space left on device); nothing written");
  EXPECT_TRUE(disk.dir().names().empty());
  // A file-size limit: the shell ignores SIGXFSZ, so write() fails with EFBIG.
  TempDir dir;
  const std::string big = dir.file("m.obj");
  expect_exit(io_fixtures::shell("trap '' XFSZ; ulimit -f 16; exec " + std::string(QJULIA_CLI) +
                                 " mesh --resolution 48 --quiet -o " + quote(big)),
              1, big + ": write failed (File too large); nothing written");
  EXPECT_TRUE(dir.names().empty());
}

TEST(CliFiles, ABadMeshFileGetsTheSameVerdictFromEveryCommand) {
  TempDir dir;
  const std::string good = sphere_file(dir, "good.glb");
  const std::string bad = write_bytes(
      dir.file("bad.ply"),
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
      "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
      "0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n");
  const std::string verdict = bad + ": vertex 1 has a non-finite position";
  expect_exit(qjulia("compare " + quote(bad) + " " + quote(good) + " --quiet"), 2, verdict);
  expect_exit(qjulia("compare " + quote(good) + " " + quote(bad) + " --quiet"), 2, verdict);
  expect_exit(qjulia("render " + quote(bad) + " -o " + quote(dir.file("x.png"))), 2, verdict);
  EXPECT_FALSE(fs::exists(dir.file("x.png")));
}

// The text of `run`'s one-line error after `path` ("" when the output does not name it).
std::string verdict_after(const io_fixtures::Run& run, const std::string& path) {
  const auto at = run.out.find(path + ": ");
  if (at == std::string::npos) return "";
  return run.out.substr(at + path.size(), run.out.find('\n', at) - at - path.size());
}

// Mutated files of every format through both commands that read meshes: the same verdict from
// each, exit 0 or 2, and on 2 the file named with the same reason and no image left. A GLB
// with 64 random bytes inserted in its body once made `compare` die with SIGSEGV while `render`
// drew it; bytes inserted into or cut from a GLB now make its header's length wrong, which is
// refused.
TEST(CliFiles, MutatedMeshFilesGetTheSameVerdictFromCompareAndRender) {
  TempDir dir;
  const std::string other = sphere_file(dir, "other.ply");
  const std::string png = dir.file("x.png");
  std::mt19937 rng(12);
  auto random_below = [&](std::size_t n) { return std::size_t(rng() % n); };
  auto verdicts = [&](const std::string& m) {
    const io_fixtures::Run c =
        qjulia("compare " + quote(m) + " " + quote(other) + " --quiet --samples 1000 --threads 1");
    const io_fixtures::Run r =
        qjulia("render " + quote(m) + " -o " + quote(png) + " --size 32 --threads 1");
    EXPECT_EQ(c.code, r.code) << m << "\ncompare: " << c.out << "\nrender: " << r.out;
    EXPECT_TRUE(c.code == 0 || c.code == 2) << m << ": " << c.out;
    if (c.code == 2) {
      EXPECT_NE(verdict_after(c, m), "") << "compare does not name " << m << ": " << c.out;
      EXPECT_EQ(verdict_after(c, m), verdict_after(r, m));
      EXPECT_FALSE(fs::exists(png));
    }
    fs::remove(png);
    return c.code;
  };
  for (const std::string& ext : kExtensions) {
    const std::string bytes = read_bytes(sphere_file(dir, "base" + ext));
    const std::size_t body = ext == ".glb" ? 12 : 0;  // after the GLB's 12-byte header
    for (int i = 0; i < 6; ++i) {
      std::string b = bytes;
      if (i % 3 == 0) {
        std::string noise(64, '\0');
        for (char& c : noise) c = char(rng());
        b.insert(body + random_below(b.size() - body), noise);
      } else if (i % 3 == 1) {
        for (std::size_t k = 1 + random_below(8); k > 0; --k)
          b[body + random_below(b.size() - body)] ^= char(1 << random_below(8));
      } else {
        b.resize(random_below(b.size()));
      }
      SCOPED_TRACE(ext + " mutation " + std::to_string(i));
      verdicts(write_bytes(dir.file("m" + ext), b));
    }
  }
  const std::string glb = read_bytes(dir.file("base.glb"));
  for (int i = 0; i < 10; ++i) {
    std::string b = glb;
    b.insert(12 + random_below(b.size() - 12), std::string(64, char(rng())));
    const std::string m = write_bytes(dir.file("inserted.glb"), b);
    EXPECT_EQ(verdicts(m), 2);
    EXPECT_EQ(verdict_after(qjulia("render " + quote(m) + " -o " + quote(png)), m),
              ": not a valid GLB file (its header says " + std::to_string(glb.size()) +
                  " bytes, the file has " + std::to_string(b.size()) + ")");
  }
}

// Bytes of the file quoted in an error (an OBJ's bad face vertex) cannot break the one line
// or reach the terminal as control characters: they are written as \xNN.
TEST(CliFiles, AnErrorQuotingTheFileStaysOneLineWithoutControlCharacters) {
  TempDir dir;
  const std::string obj =
      write_bytes(dir.file("bad.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\x1b[2J\x07\x7fz\n");
  const io_fixtures::Run r = qjulia("render " + quote(obj) + " -o " + quote(dir.file("x.png")));
  EXPECT_EQ(r.code, 2) << r.out;
  EXPECT_EQ(r.out, "qjulia render: " + obj + ": line 4: bad face vertex '3\\x1b[2J\\x07\\x7fz'\n");
}

TEST(CliFiles, AnInputThatWouldNotFitInMemoryExitsTwoBeforeItIsAllocated) {
#if defined(__SANITIZE_ADDRESS__)
  // AddressSanitizer reserves terabytes of address space: no process of a sanitizer build can
  // run under an address-space limit (the library's refusal is tested by io_test).
  GTEST_SKIP() << "an address-space limit cannot be set under AddressSanitizer";
#endif
  // 30 polygons of a million one-byte indices: a 30 MB file whose triangles take 360 MB, read
  // under a 400 MB address-space limit (the CLI itself needs some 200 MB of it).
  TempDir dir;
  std::string ply =
      "ply\nformat binary_little_endian 1.0\nelement vertex 256\nproperty uchar x\n"
      "property uchar y\nproperty uchar z\nelement face 30\n"
      "property list uint uchar vertex_indices\nend_header\n";
  for (int v = 0; v < 256; ++v) ply += std::string{char(v), char(v / 16), char(v % 7)};
  std::string face(4 + 1000000, '\0');
  const uint32_t n = 1000000;
  std::memcpy(&face[0], &n, 4);
  for (uint32_t k = 0; k < n; ++k) face[4 + k] = char(k % 251);
  for (int f = 0; f < 30; ++f) ply += face;
  const std::string big = write_bytes(dir.file("big.ply"), ply);
  const std::string good = sphere_file(dir, "good.glb");
  const std::string limit = "ulimit -v 400000; exec " + std::string(QJULIA_CLI);
  const std::string verdict = big + ": reading it needs at least ";
  expect_exit(io_fixtures::shell(limit + " compare " + quote(big) + " " + quote(good) + " --quiet"),
              2, verdict);
  expect_exit(
      io_fixtures::shell(limit + " render " + quote(big) + " -o " + quote(dir.file("x.png"))), 2,
      verdict);
  EXPECT_FALSE(fs::exists(dir.file("x.png")));
}

}  // namespace
