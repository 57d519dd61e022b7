// SIGINT and SIGTERM during every stage of `qjulia mesh`: the command exits 130 / 143 within a
// second of the signal and leaves nothing in its output folder (no output, no temporary file).
//
// The command runs on a pseudo-terminal, so it draws its progress bar and the test sees which
// stage is running; the signal is sent a moment after the stage's name appears. The runs are
// large enough that every stage lasts well over a second on the project machine.
#include <gtest/gtest.h>
#include <poll.h>
#include <pty.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

// The stage whose bar was drawn last in the terminal output `seen` ("" before the first): the
// bar is "\rSTAGE      [####    ]  42%".
std::string last_stage(const std::string& seen) {
  const auto bracket = seen.rfind('[');
  if (bracket == std::string::npos) return "";
  const auto cr = seen.rfind('\r', bracket);
  if (cr == std::string::npos) return "";
  std::string stage = seen.substr(cr + 1, bracket - cr - 1);
  while (!stage.empty() && stage.back() == ' ') stage.pop_back();
  return stage;
}

// `qjulia mesh ARGS` on a pseudo-terminal in its own empty folder.
class MeshRun {
 public:
  MeshRun(const fs::path& dir, const std::vector<std::string>& args) : dir_(dir) {
    std::vector<std::string> argv = {QJULIA_CLI, "mesh"};
    argv.insert(argv.end(), args.begin(), args.end());
    std::vector<char*> cargv;
    for (auto& a : argv) cargv.push_back(a.data());
    cargv.push_back(nullptr);
    pid_ = ::forkpty(&master_, nullptr, nullptr, nullptr);
    if (pid_ == 0) {
      if (::chdir(dir.c_str()) != 0) ::_exit(126);
      ::execv(cargv[0], cargv.data());
      ::_exit(127);
    }
  }
  ~MeshRun() {
    if (pid_ > 0 && !status_) {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, nullptr, 0);
    }
    if (master_ >= 0) ::close(master_);
  }
  bool started() const { return pid_ > 0; }

  // Reads the terminal for up to `seconds`; returns early once `stage` is the stage drawn last
  // (when given) or the command has ended.
  void read_for(double seconds, const std::string& stage = "") {
    const auto t0 = Clock::now();
    while (seconds_since(t0) < seconds && !ended()) {
      pollfd p{master_, POLLIN, 0};
      if (::poll(&p, 1, 20) > 0) {
        char buf[4096];
        const ssize_t n = ::read(master_, buf, sizeof buf);
        if (n > 0) seen_.append(buf, static_cast<std::size_t>(n));
      }
      if (!stage.empty() && last_stage(seen_) == stage) return;
    }
  }

  // True once the command has exited (its status is then kept).
  bool ended() {
    if (status_) return true;
    int status = 0;
    if (::waitpid(pid_, &status, WNOHANG) == pid_) status_ = status;
    return status_.has_value();
  }

  void signal(int sig) { ::kill(pid_, sig); }
  int exit_code() const { return status_ && WIFEXITED(*status_) ? WEXITSTATUS(*status_) : -1; }
  const std::string& seen() const { return seen_; }

  // Every file left in the folder, hidden temporary files included.
  std::vector<std::string> files() const {
    std::vector<std::string> out;
    for (const auto& e : fs::directory_iterator(dir_)) out.push_back(e.path().filename());
    return out;
  }

 private:
  fs::path dir_;
  pid_t pid_ = -1;
  int master_ = -1;
  std::optional<int> status_;
  std::string seen_;
};

struct SignalCase {
  std::string stage;              // the progress-bar stage to interrupt
  int signal;                     // SIGINT or SIGTERM
  std::vector<std::string> args;  // of qjulia mesh
};

void PrintTo(const SignalCase& c, std::ostream* os) {
  *os << (c.signal == SIGINT ? "SIGINT" : "SIGTERM") << " during " << c.stage;
}

class Signals : public ::testing::TestWithParam<SignalCase> {
 protected:
  void SetUp() override {
    std::string name = ::testing::UnitTest::GetInstance()->current_test_info()->name();
    for (char& c : name)
      if (c == '/') c = '_';
    dir_ = fs::temp_directory_path() /
           ("qjulia_signal_test_" + std::to_string(::getpid()) + "_" + name);
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_P(Signals, ExitWithinASecondWithTheSignalsCodeAndLeaveNoFile) {
  const SignalCase& c = GetParam();
  MeshRun run(dir_, c.args);
  ASSERT_TRUE(run.started());
  run.read_for(600, c.stage);
  ASSERT_EQ(last_stage(run.seen()), c.stage) << "the stage never started; terminal output:\n"
                                             << run.seen();
  run.read_for(0.3);  // well inside the stage
  ASSERT_FALSE(run.ended()) << "ended before the signal:\n" << run.seen();
  ASSERT_EQ(last_stage(run.seen()), c.stage) << "the stage ended before the signal";
  const auto t0 = Clock::now();
  run.signal(c.signal);
  run.read_for(60);
  const double seconds = seconds_since(t0);
  ASSERT_TRUE(run.ended()) << "still running 60 s after the signal";
  EXPECT_LT(seconds, 1.0) << "the " << c.stage << " stage took " << seconds
                          << " s to stop after the signal";
  EXPECT_EQ(run.exit_code(), 128 + c.signal) << run.seen();
  EXPECT_NE(run.seen().find(c.signal == SIGINT ? "SIGINT" : "SIGTERM"), std::string::npos)
      << run.seen();
  EXPECT_EQ(run.files(), std::vector<std::string>{}) << "output or temporary files left";
}

// newton-cubic at 320: about 3.4M faces; decimating them takes seconds on two cores.
const std::vector<std::string> kBig = {"--preset", "newton-cubic", "--resolution", "320"};
// Extracting them and writing them as OBJ now take 0.3-0.4 s each on two cores, about the wait
// inside the stage (a signal after the file is committed ends nothing): the extraction and
// writing cases use 512 (9.9M faces, about a second each), the sampling cases 640 (about 2 s).
const std::vector<std::string> kLong = {"--preset", "newton-cubic", "--resolution", "512"};
const std::vector<std::string> kBigSample = {"--preset", "newton-cubic", "--resolution", "640"};

std::vector<std::string> with(std::vector<std::string> args, const std::vector<std::string>& more) {
  args.insert(args.end(), more.begin(), more.end());
  return args;
}

INSTANTIATE_TEST_SUITE_P(
    MeshStages, Signals,
    ::testing::Values(
        SignalCase{"sample", SIGINT, with(kBigSample, {"-o", "out.ply"})},
        SignalCase{"sample", SIGTERM, with(kBigSample, {"-o", "out.ply"})},
        SignalCase{"extract", SIGTERM, with(kLong, {"-o", "out.ply"})},
        SignalCase{"extract", SIGINT, with(kLong, {"-o", "out.ply"})},
        SignalCase{"decimate", SIGINT, with(kBig, {"--faces", "20000", "-o", "out.ply"})},
        SignalCase{"write", SIGTERM, with(kLong, {"-o", "out.obj", "--stats", "s.json"})},
        SignalCase{"write", SIGINT, with(kLong, {"-o", "out.obj"})}),
    [](const ::testing::TestParamInfo<SignalCase>& info) {
      return info.param.stage + (info.param.signal == SIGINT ? "_SIGINT" : "_SIGTERM");
    });

}  // namespace
