// Tests for MetricsHttpServer over real loopback sockets.
#include "common/metrics_http.h"

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <map>
#include <stdexcept>
#include <string>
#include <string_view>
#include <thread>

#include "tests/test_util.h"

namespace pf {
namespace {

// Returns a socket connected to 127.0.0.1:`port`, or -1.
int Connect(int port) {
  const int fd = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  timeval timeout{5, 0};
  setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof(timeout));
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(static_cast<uint16_t>(port));
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof(address)) != 0) {
    close(fd);
    return -1;
  }
  return fd;
}

// Sends `request` (then half-closes when `half_close`) and returns everything
// the server sends back until it closes the connection.
std::string Exchange(int port, std::string_view request, bool half_close = false) {
  const int fd = Connect(port);
  if (fd < 0) return "";
  send(fd, request.data(), request.size(), MSG_NOSIGNAL);
  if (half_close) shutdown(fd, SHUT_WR);
  std::string response;
  char buffer[4096];
  ssize_t n;
  while ((n = recv(fd, buffer, sizeof(buffer), 0)) > 0) response.append(buffer, n);
  close(fd);
  return response;
}

struct HttpResponse {
  int code = 0;
  std::map<std::string, std::string> headers;
  std::string body;
};

// Splits a raw response into status code, headers and body.
HttpResponse Parse(const std::string& raw) {
  HttpResponse response;
  const size_t head_end = raw.find("\r\n\r\n");
  if (raw.rfind("HTTP/1.1 ", 0) != 0 || head_end == std::string::npos) return response;
  response.code = std::stoi(raw.substr(9, 3));
  size_t line_start = raw.find("\r\n") + 2;
  while (line_start < head_end) {
    const size_t line_end = raw.find("\r\n", line_start);
    const std::string line = raw.substr(line_start, line_end - line_start);
    const size_t colon = line.find(": ");
    response.headers[line.substr(0, colon)] = line.substr(colon + 2);
    line_start = line_end + 2;
  }
  response.body = raw.substr(head_end + 4);
  return response;
}

HttpResponse Get(int port, std::string_view path) {
  return Parse(Exchange(
      port, std::string("GET ") + std::string(path) + " HTTP/1.1\r\nHost: localhost\r\n\r\n"));
}

class MetricsHttpServerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    registry_.Counter("pf_tasks_completed_total", "Tasks completed.", {{"kind", "render"}}).Inc(7);
    registry_.CallbackGauge("pf_queue_depth", "Jobs waiting.", {{"kind", "render"}},
                            [this] { return static_cast<double>(depth_.load()); });
    ASSERT_TRUE(server_.Start().ok());
    ASSERT_GT(server_.port(), 0);
  }

  MetricsRegistry registry_;
  std::atomic<int> depth_{4};
  MetricsHttpServer server_{"127.0.0.1:0", &registry_};
};

TEST_F(MetricsHttpServerTest, ServesTheRenderedRegistry) {
  HttpResponse response = Get(server_.port(), "/metrics");
  EXPECT_EQ(response.code, 200);
  EXPECT_EQ(response.headers["Content-Type"], "text/plain; version=0.0.4; charset=utf-8");
  EXPECT_EQ(response.headers["Connection"], "close");
  EXPECT_EQ(response.headers["Content-Length"], std::to_string(response.body.size()));
  EXPECT_EQ(response.body, registry_.Render());
  EXPECT_EQ(response.body,
            "# HELP pf_tasks_completed_total Tasks completed.\n"
            "# TYPE pf_tasks_completed_total counter\n"
            "pf_tasks_completed_total{kind=\"render\"} 7\n"
            "# HELP pf_queue_depth Jobs waiting.\n"
            "# TYPE pf_queue_depth gauge\n"
            "pf_queue_depth{kind=\"render\"} 4\n");

  // Each scrape renders afresh, callback gauges included.
  depth_ = 9;
  EXPECT_NE(Get(server_.port(), "/metrics?x=1").body.find("pf_queue_depth{kind=\"render\"} 9\n"),
            std::string::npos);
}

TEST_F(MetricsHttpServerTest, AnswersHealthzAndRejectsOtherPathsAndMethods) {
  const HttpResponse health = Get(server_.port(), "/healthz");
  EXPECT_EQ(health.code, 200);
  EXPECT_EQ(health.body, "ok\n");
  EXPECT_EQ(Get(server_.port(), "/nope").code, 404);
  EXPECT_EQ(Get(server_.port(), "/metrics/extra").code, 404);
  EXPECT_EQ(Parse(Exchange(server_.port(), "POST /metrics HTTP/1.1\r\n\r\n")).code, 405);
  // HTTP/1.0 and bare "\n" line ends are accepted too.
  EXPECT_EQ(Parse(Exchange(server_.port(), "GET /healthz HTTP/1.0\n\n")).code, 200);
}

TEST_F(MetricsHttpServerTest, GarbageGets400AndTheServerKeepsAnswering) {
  const std::string garbage("\x16\x03\x01\x02\x00\xff\xfe garbage\r\n\r\n", 20);
  EXPECT_EQ(Parse(Exchange(server_.port(), garbage)).code, 400);
  EXPECT_EQ(Parse(Exchange(server_.port(), "GET\r\n\r\n")).code, 400);
  EXPECT_EQ(Parse(Exchange(server_.port(), "GET metrics HTTP/1.1\r\n\r\n")).code, 400);
  EXPECT_EQ(Parse(Exchange(server_.port(), "GET /metrics HTTP/9\r\n\r\n")).code, 400);
  EXPECT_EQ(Parse(Exchange(server_.port(), "GET /metrics HTTP/1.1\r\nno colon\r\n\r\n")).code, 400);
  EXPECT_EQ(Parse(Exchange(server_.port(), "GET /metrics\tHTTP/1.1\r\n\r\n")).code, 400);
  // A tab inside a header value is fine.
  EXPECT_EQ(Parse(Exchange(server_.port(), "GET /healthz HTTP/1.1\r\nX-A:\tb\r\n\r\n")).code, 200);
  // A request cut short by the client, and one too long to be a request head.
  EXPECT_EQ(Parse(Exchange(server_.port(), "GET /met", /*half_close=*/true)).code, 400);
  EXPECT_EQ(Parse(Exchange(server_.port(), std::string(20000, 'A'))).code, 400);
  // A client that connects and leaves without a byte gets nothing.
  EXPECT_EQ(Exchange(server_.port(), "", /*half_close=*/true), "");

  EXPECT_EQ(Get(server_.port(), "/metrics").code, 200);
}

TEST(MetricsHttpServer, ThrowingCallbackGets500AndTheServerKeepsAnswering) {
  MetricsRegistry registry;
  registry.CallbackGauge("broken", "Throws.", {},
                         []() -> double { throw std::runtime_error("store closed"); });
  MetricsHttpServer server("127.0.0.1:0", &registry);
  ASSERT_TRUE(server.Start().ok());
  EXPECT_EQ(Get(server.port(), "/metrics").code, 500);
  EXPECT_EQ(Get(server.port(), "/healthz").code, 200);
}

TEST_F(MetricsHttpServerTest, ServesManyConnectionsOneAfterAnother) {
  for (int i = 0; i < 50; ++i) {
    depth_ = i;
    const HttpResponse response = Get(server_.port(), "/metrics");
    ASSERT_EQ(response.code, 200) << "request " << i;
    EXPECT_NE(response.body.find("pf_queue_depth{kind=\"render\"} " + std::to_string(i) + "\n"),
              std::string::npos);
  }
}

TEST_F(MetricsHttpServerTest, StopReturnsPromptlyWithAnIdleClientConnected) {
  // The server is blocked reading from this client when Stop() is called.
  const int idle = Connect(server_.port());
  ASSERT_GE(idle, 0);
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  const auto start = std::chrono::steady_clock::now();
  server_.Stop();
  const auto elapsed = std::chrono::steady_clock::now() - start;
  EXPECT_LT(elapsed, testing::Scaled(std::chrono::milliseconds(500)));
  close(idle);
  EXPECT_EQ(Connect(server_.port()), -1);  // no longer listening
  server_.Stop();                          // a second Stop() is harmless
}

TEST_F(MetricsHttpServerTest, StartTwiceFails) {
  EXPECT_EQ(server_.Start().code(), absl::StatusCode::kFailedPrecondition);
}

TEST_F(MetricsHttpServerTest, SecondServerOnTheSamePortIsUnavailable) {
  MetricsHttpServer second("127.0.0.1:" + std::to_string(server_.port()), &registry_);
  const absl::Status status = second.Start();
  EXPECT_EQ(status.code(), absl::StatusCode::kUnavailable);
  EXPECT_NE(std::string(status.message()).find("--metrics-listen"), std::string::npos);
  EXPECT_NE(std::string(status.message()).find("in use"), std::string::npos);
  // The first one is unaffected.
  EXPECT_EQ(Get(server_.port(), "/healthz").code, 200);
}

TEST(MetricsHttpServer, MalformedAddressesAreInvalidArguments) {
  MetricsRegistry registry;
  for (const char* listen : {"localhost", "localhost:", "localhost:99999", "localhost:http",
                             "::1:9464", "[::1", "[::1]9464", ":-1", "no.such.host.invalid:0"}) {
    MetricsHttpServer server(listen, &registry);
    const absl::Status status = server.Start();
    EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument) << listen;
    EXPECT_NE(std::string(status.message()).find("--metrics-listen"), std::string::npos)
        << status.message();
  }
}

TEST(MetricsHttpServer, EmptyHostListensOnAllInterfaces) {
  MetricsRegistry registry;
  MetricsHttpServer server(":0", &registry);
  ASSERT_TRUE(server.Start().ok());
  EXPECT_EQ(Get(server.port(), "/healthz").code, 200);  // reached via 127.0.0.1
}

}  // namespace
}  // namespace pf
