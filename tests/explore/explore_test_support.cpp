#include "explore_test_support.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstring>
#include <regex>
#include <stdexcept>
#include <thread>

extern char** environ;

namespace qjulia::test {
namespace {

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

std::vector<char*> c_strings(std::vector<std::string>& strings) {
  std::vector<char*> v;
  for (auto& s : strings) v.push_back(s.data());
  v.push_back(nullptr);
  return v;
}

}  // namespace

HttpResponse send_raw(const std::string& address, int port, const std::string& request) {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) throw std::runtime_error("socket failed");
  sockaddr_in sa{};
  sa.sin_family = AF_INET;
  sa.sin_port = htons(static_cast<uint16_t>(port));
  inet_pton(AF_INET, address.c_str(), &sa.sin_addr);
  if (connect(fd, reinterpret_cast<sockaddr*>(&sa), sizeof sa) != 0) {
    const int e = errno;
    close(fd);
    throw std::runtime_error("cannot connect to " + address + ":" + std::to_string(port) + ": " +
                             std::strerror(e));
  }
  timeval timeout{120, 0};
  setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);
  for (std::size_t sent = 0; sent < request.size();) {
    const ssize_t n = send(fd, request.data() + sent, request.size() - sent, MSG_NOSIGNAL);
    if (n <= 0) break;  // the server may answer (and close) before it read everything
    sent += static_cast<std::size_t>(n);
  }
  std::string raw;
  char buffer[65536];
  for (;;) {
    const ssize_t n = recv(fd, buffer, sizeof buffer, 0);
    if (n <= 0) break;
    raw.append(buffer, static_cast<std::size_t>(n));
  }
  close(fd);
  HttpResponse r;
  const std::size_t end = raw.find("\r\n\r\n");
  if (raw.compare(0, 9, "HTTP/1.1 ") != 0 || end == std::string::npos)
    throw std::runtime_error("not an HTTP response: '" + raw.substr(0, 200) + "'");
  r.status = std::stoi(raw.substr(9, 3));
  std::size_t line = raw.find("\r\n") + 2;
  while (line < end) {
    const std::size_t next = raw.find("\r\n", line);
    const std::string h = raw.substr(line, next - line);
    const std::size_t colon = h.find(':');
    if (colon != std::string::npos) {
      std::size_t v = colon + 1;
      while (v < h.size() && h[v] == ' ') ++v;
      r.headers[lower(h.substr(0, colon))] = h.substr(v);
    }
    line = next + 2;
  }
  r.body = raw.substr(end + 4);
  return r;
}

std::string make_request(const std::string& method, const std::string& path,
                         const std::vector<Header>& headers, const std::string* body) {
  std::string r = method + " " + path + " HTTP/1.1\r\n";
  for (const auto& h : headers) r += h + "\r\n";
  if (body)
    r += "Content-Type: application/json\r\nContent-Length: " + std::to_string(body->size()) +
         "\r\n";
  r += "Connection: close\r\n\r\n";
  if (body) r += *body;
  return r;
}

ExploreServer::ExploreServer(const std::vector<std::string>& args, const std::string& tmpdir) {
  int pipe_fds[2];
  if (pipe(pipe_fds) != 0) throw std::runtime_error("pipe failed");
  std::vector<std::string> argv = {QJULIA_CLI, "explore", "--no-browser", "--port", "0"};
  argv.insert(argv.end(), args.begin(), args.end());
  std::vector<std::string> env;
  for (char** e = environ; *e; ++e)
    if (tmpdir.empty() || std::strncmp(*e, "TMPDIR=", 7) != 0) env.emplace_back(*e);
  if (!tmpdir.empty()) env.push_back("TMPDIR=" + tmpdir);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, pipe_fds[1], 1);
  posix_spawn_file_actions_addclose(&actions, pipe_fds[0]);
  auto cargv = c_strings(argv);
  auto cenv = c_strings(env);
  const int rc = posix_spawn(&pid_, argv[0].c_str(), &actions, nullptr, cargv.data(), cenv.data());
  posix_spawn_file_actions_destroy(&actions);
  close(pipe_fds[1]);
  if (rc != 0) throw std::runtime_error("cannot start " + argv[0]);
  // The first line names the address.
  std::string out;
  static const std::regex kServing(R"(serving http://\[?([0-9a-fA-F.:]+)\]?:(\d+)/)");
  std::smatch m;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (!std::regex_search(out, m, kServing)) {
    pollfd p{pipe_fds[0], POLLIN, 0};
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
        deadline - std::chrono::steady_clock::now());
    char buffer[256];
    ssize_t n = 0;
    if (left.count() <= 0 || poll(&p, 1, static_cast<int>(left.count())) <= 0 ||
        (n = read(pipe_fds[0], buffer, sizeof buffer)) <= 0) {
      close(pipe_fds[0]);
      kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
      throw std::runtime_error("qjulia explore printed no address: '" + out + "'");
    }
    out.append(buffer, static_cast<std::size_t>(n));
  }
  out_fd_ = pipe_fds[0];
  address_ = m[1].str();
  port_ = std::stoi(m[2].str());
}

ExploreServer::~ExploreServer() {
  // SIGTERM first, so the server removes its private directory ($TMPDIR/qjulia-explore-*);
  // SIGKILL only when it does not end.
  if (pid_ > 0 && stop(SIGTERM, 10) < 0 && pid_ > 0) {
    kill(pid_, SIGKILL);
    waitpid(pid_, nullptr, 0);
  }
  if (out_fd_ >= 0) close(out_fd_);
}

HttpResponse ExploreServer::get(const std::string& path, const std::vector<Header>& headers) const {
  std::vector<Header> all = {"Host: " + host()};
  all.insert(all.end(), headers.begin(), headers.end());
  return send_raw(address_, port_, make_request("GET", path, all));
}

HttpResponse ExploreServer::post(const std::string& path, const std::string& body,
                                 const std::vector<Header>& headers) const {
  std::vector<Header> all = {"Host: " + host()};
  all.insert(all.end(), headers.begin(), headers.end());
  return send_raw(address_, port_, make_request("POST", path, all, &body));
}

int ExploreServer::stop(int signal, double timeout_s) {
  if (pid_ <= 0) return -1;
  kill(pid_, signal);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  int status = 0;
  while (waitpid(pid_, &status, WNOHANG) == 0) {
    if (std::chrono::steady_clock::now() > deadline) return -1;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  pid_ = -1;
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  return WIFSIGNALED(status) ? 128 + WTERMSIG(status) : -1;
}

int run_cli(const std::vector<std::string>& argv, const std::string& dir, std::string* err) {
  std::string command = "cd '" + dir + "' &&";
  for (const auto& a : argv) command += " '" + a + "'";
  command += " 2>&1 >/dev/null";
  FILE* pipe = popen(command.c_str(), "r");
  if (!pipe) throw std::runtime_error("popen failed");
  std::string out;
  char buffer[4096];
  std::size_t n;
  while ((n = fread(buffer, 1, sizeof buffer, pipe)) > 0) out.append(buffer, n);
  const int status = pclose(pipe);
  if (err) *err = out;
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

}  // namespace qjulia::test
