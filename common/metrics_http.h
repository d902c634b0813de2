// A minimal HTTP/1.1 server that exposes a MetricsRegistry to Prometheus.
//
//   pf::MetricsHttpServer metrics("0.0.0.0:9464", &pf::DefaultMetrics());
//   RETURN_IF_ERROR(metrics.Start());   // serves until Stop() or destruction
//
// It answers
//   GET /metrics  200, Content-Type: text/plain; version=0.0.4; charset=utf-8,
//                 the registry's Render()
//   GET /healthz  200 "ok\n"
//   GET (other)   404;  another method 405;  a malformed request 400
// one connection at a time on a background thread, each closed after its
// response (no keep-alive). Plain POSIX sockets; a slow or silent client is
// dropped after a few seconds and never delays Stop().
#ifndef POINTFORWARD_COMMON_METRICS_HTTP_H_
#define POINTFORWARD_COMMON_METRICS_HTTP_H_

#include <string>
#include <thread>

#include "absl/status/status.h"
#include "common/metrics.h"

namespace pf {

class MetricsHttpServer {
 public:
  // `listen` is "HOST:PORT" as given by --metrics-listen: HOST is a name, an
  // IPv4 address, a bracketed IPv6 address ("[::1]") or empty for all
  // interfaces; PORT 0 picks a free port. `registry` must outlive the server.
  explicit MetricsHttpServer(std::string listen, MetricsRegistry* registry = &DefaultMetrics());
  // Calls Stop().
  ~MetricsHttpServer();
  MetricsHttpServer(const MetricsHttpServer&) = delete;
  MetricsHttpServer& operator=(const MetricsHttpServer&) = delete;

  // Binds, listens and starts serving on a background thread. Fails with
  // INVALID_ARGUMENT when the address is malformed or its host does not
  // resolve, UNAVAILABLE when it cannot be bound (port taken), and
  // FAILED_PRECONDITION when already started.
  absl::Status Start();

  // Stops serving and joins the thread; an open connection is dropped.
  // Returns at once when not started; safe to call more than once.
  void Stop();

  // Returns the bound port (the chosen one for port 0); 0 before Start().
  int port() const { return port_; }

 private:
  void Serve();
  void HandleConnection(int fd);
  // Returns the full response for `head` (the request up to its blank line).
  std::string Respond(const std::string& head) const;

  const std::string listen_;
  MetricsRegistry* const registry_;
  int listen_fd_ = -1;
  int wake_read_fd_ = -1;  // self-pipe: readable once Stop() is called
  int wake_write_fd_ = -1;
  int port_ = 0;
  std::thread thread_;
};

}  // namespace pf

#endif  // POINTFORWARD_COMMON_METRICS_HTTP_H_
