#pragma once
// What the tests of `qjulia explore` share: the server as a child process and a plain HTTP
// client over a socket, so every header (Host, Origin, Content-Length) is the test's to choose.
#include <sys/types.h>

#include <map>
#include <string>
#include <vector>

namespace qjulia::test {

/// An HTTP response: status, headers (names in lower case) and body.
struct HttpResponse {
  int status = 0;
  std::map<std::string, std::string> headers;
  std::string body;
  /// The value of header `name` (lower case), "" when absent.
  std::string header(const std::string& name) const {
    const auto it = headers.find(name);
    return it == headers.end() ? "" : it->second;
  }
};

/// Sends `request` (the raw bytes) to address:port and reads the response until the server
/// closes the connection (it closes after every response). @throws std::runtime_error when
/// the connection fails.
HttpResponse send_raw(const std::string& address, int port, const std::string& request);

/// One header line of a request, without the CRLF: "Origin: http://evil.example".
using Header = std::string;

/// A request: `method` `path` HTTP/1.1 with the given headers, then Content-Length and the body
/// when `body` is given.
std::string make_request(const std::string& method, const std::string& path,
                         const std::vector<Header>& headers, const std::string* body = nullptr);

/// `qjulia explore --no-browser --port 0 ARGS...` as a child process.
class ExploreServer {
 public:
  /// Starts the server and waits until it prints its address.
  /// @param[in] args    more arguments (a preset, --listen, ...)
  /// @param[in] tmpdir  TMPDIR of the server ("" keeps the test's)
  explicit ExploreServer(const std::vector<std::string>& args = {}, const std::string& tmpdir = "");
  ~ExploreServer();  ///< stops the server (SIGTERM, then SIGKILL) if it still runs
  ExploreServer(const ExploreServer&) = delete;
  ExploreServer& operator=(const ExploreServer&) = delete;

  int port() const { return port_; }
  /// The address it listens on, as printed ("127.0.0.1").
  const std::string& address() const { return address_; }
  /// "127.0.0.1:PORT", the Host of every request below.
  std::string host() const { return address_ + ":" + std::to_string(port_); }

  HttpResponse get(const std::string& path, const std::vector<Header>& headers = {}) const;
  HttpResponse post(const std::string& path, const std::string& body,
                    const std::vector<Header>& headers = {}) const;

  /// Sends `signal` and waits (at most `timeout_s`) for the exit. @return the exit code
  /// (128 + signal for a process that the signal killed), -1 on a timeout.
  int stop(int signal, double timeout_s = 20);

 private:
  pid_t pid_ = -1;
  int out_fd_ = -1;  // the server's stdout, open while it runs
  int port_ = 0;
  std::string address_;
};

/// Runs `argv` (the CLI and its arguments) in `dir` and returns its exit code; its stderr goes
/// to `err`.
int run_cli(const std::vector<std::string>& argv, const std::string& dir, std::string* err);

}  // namespace qjulia::test
