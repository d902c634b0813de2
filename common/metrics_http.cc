// MetricsHttpServer: poll() on the listening socket and a self-pipe, one
// connection handled at a time with a deadline.
#include "common/metrics_http.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <poll.h>
#include <spdlog/spdlog.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <exception>
#include <string_view>
#include <utility>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/string_view.h"

namespace pf {
namespace {

using Clock = std::chrono::steady_clock;

constexpr char kFlag[] = "--metrics-listen";
constexpr size_t kMaxRequestBytes = 8192;
constexpr auto kConnectionDeadline = std::chrono::seconds(5);
constexpr auto kDrainDeadline = std::chrono::milliseconds(200);

struct HostPort {
  std::string host;  // empty: all interfaces
  std::string port;
};

// Splits "HOST:PORT" / "[V6]:PORT"; INVALID_ARGUMENT naming the flag otherwise.
absl::StatusOr<HostPort> ParseListen(const std::string& listen) {
  const auto malformed = [&](absl::string_view why) {
    return absl::InvalidArgumentError(
        absl::StrCat(kFlag, ": '", listen, "' is not HOST:PORT (", why, ")"));
  };
  HostPort parsed;
  std::string_view rest;
  if (!listen.empty() && listen[0] == '[') {
    const size_t close = listen.find(']');
    if (close == std::string::npos) return malformed("unclosed '['");
    parsed.host = listen.substr(1, close - 1);
    if (close + 1 >= listen.size() || listen[close + 1] != ':') {
      return malformed("expected ':' after ']'");
    }
    rest = std::string_view(listen).substr(close + 2);
  } else {
    const size_t colon = listen.rfind(':');
    if (colon == std::string::npos) return malformed("no ':PORT'");
    parsed.host = listen.substr(0, colon);
    if (parsed.host.find(':') != std::string::npos) {
      return malformed("write an IPv6 host in brackets");
    }
    rest = std::string_view(listen).substr(colon + 1);
  }
  if (rest.empty() || rest.size() > 5 ||
      rest.find_first_not_of("0123456789") != std::string_view::npos ||
      std::stoi(std::string(rest)) > 65535) {
    return malformed("PORT must be a number in [0, 65535]");
  }
  parsed.port = std::string(rest);
  return parsed;
}

enum class Wait { kReady, kStopped, kTimedOut };

// Waits until `fd` has `events`, `wake_fd` is readable (Stop) or `deadline`.
Wait WaitFor(int fd, short events, int wake_fd, Clock::time_point deadline) {
  while (true) {
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now());
    if (left.count() <= 0) return Wait::kTimedOut;
    pollfd fds[2] = {{fd, events, 0}, {wake_fd, POLLIN, 0}};
    const int n = poll(fds, 2, static_cast<int>(left.count()));
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 || fds[1].revents != 0) return Wait::kStopped;
    if (fds[0].revents != 0) return Wait::kReady;
  }
}

// Returns the length of the head (request line and headers) ended by a blank
// line, or npos while incomplete. Accepts bare "\n" line ends.
size_t HeadEnd(const std::string& data) {
  const size_t crlf = data.find("\r\n\r\n");
  const size_t lf = data.find("\n\n");
  if (crlf == std::string::npos && lf == std::string::npos) return std::string::npos;
  return std::min(crlf == std::string::npos ? lf + 2 : crlf + 4,
                  lf == std::string::npos ? crlf + 4 : lf + 2);
}

std::string Response(int code, absl::string_view reason, absl::string_view content_type,
                     absl::string_view body) {
  return absl::StrCat("HTTP/1.1 ", code, " ", reason, "\r\nContent-Type: ", content_type,
                      "\r\nContent-Length: ", body.size(), "\r\nConnection: close\r\n\r\n", body);
}

std::string TextResponse(int code, absl::string_view reason, absl::string_view body) {
  return Response(code, reason, "text/plain; charset=utf-8", body);
}

// Returns whether `token` is a non-empty run of upper-case letters (a method).
bool IsMethod(std::string_view token) {
  if (token.empty()) return false;
  for (char c : token) {
    if (c < 'A' || c > 'Z') return false;
  }
  return true;
}

// Returns whether `line` is printable ASCII (no control or high bytes; tabs
// only when `allow_tab`, as header values may hold them).
bool IsPrintable(std::string_view line, bool allow_tab) {
  for (char c : line) {
    const auto u = static_cast<unsigned char>(c);
    if ((u < 0x20 && !(allow_tab && c == '\t')) || u > 0x7e) return false;
  }
  return true;
}

// Splits `head` into lines, dropping "\r" before "\n".
std::vector<std::string_view> Lines(std::string_view head) {
  std::vector<std::string_view> lines;
  while (!head.empty()) {
    const size_t end = head.find('\n');
    std::string_view line = head.substr(0, end);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    lines.push_back(line);
    if (end == std::string_view::npos) break;
    head.remove_prefix(end + 1);
  }
  return lines;
}

}  // namespace

MetricsHttpServer::MetricsHttpServer(std::string listen, MetricsRegistry* registry)
    : listen_(std::move(listen)), registry_(registry) {}

MetricsHttpServer::~MetricsHttpServer() { Stop(); }

absl::Status MetricsHttpServer::Start() {
  if (thread_.joinable()) {
    return absl::FailedPreconditionError("metrics server already started");
  }
  absl::StatusOr<HostPort> address = ParseListen(listen_);
  if (!address.ok()) return address.status();

  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = AI_PASSIVE | AI_NUMERICSERV;
  addrinfo* results = nullptr;
  const int gai = getaddrinfo(address->host.empty() ? nullptr : address->host.c_str(),
                              address->port.c_str(), &hints, &results);
  if (gai != 0) {
    return absl::InvalidArgumentError(
        absl::StrCat(kFlag, ": cannot resolve host '", address->host, "': ", gai_strerror(gai)));
  }
  // Bind the first address that works.
  int bind_errno = 0;
  for (addrinfo* ai = results; ai != nullptr && listen_fd_ < 0; ai = ai->ai_next) {
    const int fd =
        socket(ai->ai_family, ai->ai_socktype | SOCK_CLOEXEC | SOCK_NONBLOCK, ai->ai_protocol);
    if (fd < 0) {
      bind_errno = errno;
      continue;
    }
    const int one = 1;
    setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof(one));
    if (bind(fd, ai->ai_addr, ai->ai_addrlen) == 0 && listen(fd, 16) == 0) {
      listen_fd_ = fd;
    } else {
      bind_errno = errno;
      close(fd);
    }
  }
  freeaddrinfo(results);
  if (listen_fd_ < 0) {
    return absl::UnavailableError(
        absl::StrCat(kFlag, ": cannot listen on ", listen_, ": ", std::strerror(bind_errno)));
  }

  sockaddr_storage bound{};
  socklen_t bound_size = sizeof(bound);
  getsockname(listen_fd_, reinterpret_cast<sockaddr*>(&bound), &bound_size);
  port_ = ntohs(bound.ss_family == AF_INET6 ? reinterpret_cast<sockaddr_in6*>(&bound)->sin6_port
                                            : reinterpret_cast<sockaddr_in*>(&bound)->sin_port);

  int pipe_fds[2];
  if (pipe2(pipe_fds, O_CLOEXEC | O_NONBLOCK) != 0) {
    const int pipe_errno = errno;
    close(listen_fd_);
    listen_fd_ = -1;
    return absl::InternalError(absl::StrCat("metrics server: pipe: ", std::strerror(pipe_errno)));
  }
  wake_read_fd_ = pipe_fds[0];
  wake_write_fd_ = pipe_fds[1];
  thread_ = std::thread([this] { Serve(); });
  spdlog::info("metrics: serving /metrics on {} (port {})", listen_, port_);
  return absl::OkStatus();
}

void MetricsHttpServer::Stop() {
  if (!thread_.joinable()) return;
  const char byte = 1;
  while (write(wake_write_fd_, &byte, 1) < 0 && errno == EINTR) {
  }
  thread_.join();
  for (int* fd : {&listen_fd_, &wake_read_fd_, &wake_write_fd_}) {
    close(*fd);
    *fd = -1;
  }
}

void MetricsHttpServer::Serve() {
  while (true) {
    pollfd fds[2] = {{listen_fd_, POLLIN, 0}, {wake_read_fd_, POLLIN, 0}};
    if (poll(fds, 2, -1) < 0) {
      if (errno == EINTR) continue;
      spdlog::error("metrics: poll: {}", std::strerror(errno));
      return;
    }
    if (fds[1].revents != 0) return;
    const int fd = accept4(listen_fd_, nullptr, nullptr, SOCK_CLOEXEC | SOCK_NONBLOCK);
    if (fd < 0) {
      if (errno == EMFILE || errno == ENFILE || errno == ENOMEM || errno == ENOBUFS) {
        // Out of resources: back off instead of spinning on the pending connection.
        spdlog::warn("metrics: accept: {}", std::strerror(errno));
        if (WaitFor(wake_read_fd_, POLLIN, wake_read_fd_,
                    Clock::now() + std::chrono::milliseconds(100)) == Wait::kStopped) {
          return;
        }
      }
      continue;  // EAGAIN, ECONNABORTED, EINTR: the next poll() sorts it out
    }
    HandleConnection(fd);
    close(fd);
  }
}

void MetricsHttpServer::HandleConnection(int fd) {
  const Clock::time_point deadline = Clock::now() + kConnectionDeadline;
  // Read the head; a client that closes early gets 400 if it sent anything.
  std::string request;
  std::string response;
  char buffer[4096];
  while (response.empty()) {
    if (WaitFor(fd, POLLIN, wake_read_fd_, deadline) != Wait::kReady) return;
    const ssize_t n = recv(fd, buffer, sizeof(buffer), 0);
    if (n < 0) {
      if (errno == EAGAIN || errno == EINTR) continue;
      return;
    }
    if (n == 0) {
      if (request.empty()) return;
      response = TextResponse(400, "Bad Request", "incomplete request\n");
      break;
    }
    request.append(buffer, static_cast<size_t>(n));
    const size_t head_end = HeadEnd(request);
    if (head_end != std::string::npos) {
      response = Respond(request.substr(0, head_end));
    } else if (request.size() > kMaxRequestBytes) {
      response = TextResponse(400, "Bad Request", "request head too large\n");
    }
  }

  // Write the response.
  std::string_view left = response;
  while (!left.empty()) {
    if (WaitFor(fd, POLLOUT, wake_read_fd_, deadline) != Wait::kReady) return;
    const ssize_t n = send(fd, left.data(), left.size(), MSG_NOSIGNAL);
    if (n < 0) {
      if (errno == EAGAIN || errno == EINTR) continue;
      return;
    }
    left.remove_prefix(static_cast<size_t>(n));
  }

  // Half-close, then drain briefly so that unread request bytes do not make
  // close() reset the connection before the client has read the response.
  shutdown(fd, SHUT_WR);
  const Clock::time_point drain_deadline = Clock::now() + kDrainDeadline;
  while (WaitFor(fd, POLLIN, wake_read_fd_, drain_deadline) == Wait::kReady) {
    const ssize_t n = recv(fd, buffer, sizeof(buffer), 0);
    if (n == 0 || (n < 0 && errno != EAGAIN && errno != EINTR)) break;
  }
}

std::string MetricsHttpServer::Respond(const std::string& head) const {
  const std::vector<std::string_view> lines = Lines(head);
  // Request line: METHOD SP TARGET SP HTTP/1.x
  const std::string_view line = lines.empty() ? std::string_view() : lines[0];
  const size_t sp1 = line.find(' ');
  const size_t sp2 = sp1 == std::string_view::npos ? sp1 : line.find(' ', sp1 + 1);
  if (!IsPrintable(line, /*allow_tab=*/false) || sp2 == std::string_view::npos ||
      line.find(' ', sp2 + 1) != std::string_view::npos) {
    return TextResponse(400, "Bad Request", "malformed request line\n");
  }
  const std::string_view method = line.substr(0, sp1);
  const std::string_view target = line.substr(sp1 + 1, sp2 - sp1 - 1);
  const std::string_view version = line.substr(sp2 + 1);
  if (!IsMethod(method) || target.empty() || target[0] != '/' ||
      (version != "HTTP/1.0" && version != "HTTP/1.1")) {
    return TextResponse(400, "Bad Request", "malformed request line\n");
  }
  for (size_t i = 1; i < lines.size(); ++i) {
    if (lines[i].empty()) continue;
    if (lines[i].find(':') == std::string_view::npos ||
        !IsPrintable(lines[i], /*allow_tab=*/true)) {
      return TextResponse(400, "Bad Request", "malformed header line\n");
    }
  }

  if (method != "GET") return TextResponse(405, "Method Not Allowed", "only GET\n");
  const std::string_view path = target.substr(0, target.find('?'));
  if (path == "/healthz") return TextResponse(200, "OK", "ok\n");
  if (path != "/metrics") return TextResponse(404, "Not Found", "not found\n");
  try {
    return Response(200, "OK", "text/plain; version=0.0.4; charset=utf-8", registry_->Render());
  } catch (const std::exception& e) {
    // A callback gauge threw: report it rather than lose the server thread.
    spdlog::error("metrics: rendering failed: {}", e.what());
    return TextResponse(500, "Internal Server Error", "metrics rendering failed\n");
  }
}

}  // namespace pf
