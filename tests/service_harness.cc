// Child processes for the service tests: see service_harness.h.
#include "tests/service_harness.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <condition_variable>
#include <cstdlib>
#include <fstream>
#include <mutex>
#include <sstream>
#include <thread>

#include "grpcpp/create_channel.h"
#include "grpcpp/generic/generic_stub.h"
#include "grpcpp/grpcpp.h"
#include "grpcpp/health_check_service_interface.h"
#include "tests/test_util.h"

namespace pf::testing {
namespace {

int DecodeStatus(int status) {
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
  return -1;
}

// A free TCP port on loopback, found by binding port 0.
int FreePort() {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  addr.sin_port = 0;
  bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr));
  socklen_t len = sizeof(addr);
  getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len);
  close(fd);
  return ntohs(addr.sin_port);
}

}  // namespace

// True when grpc.health.v1.Health/Check answers SERVING (status field 1 = 1).
bool Serving(const std::string& address, const ChannelOptions& channel_options) {
  auto channel = MakeChannel(address, channel_options);
  grpc::GenericStub stub(channel);
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + Scaled(std::chrono::seconds(1)));
  grpc::Slice empty_message("");  // An empty HealthCheckRequest: the whole server.
  grpc::ByteBuffer request(&empty_message, 1);
  grpc::ByteBuffer response;
  grpc::Status status;
  bool done = false;
  std::mutex mu;
  std::condition_variable cv;
  stub.UnaryCall(&context, "/grpc.health.v1.Health/Check", grpc::StubOptions(), &request, &response,
                 [&](grpc::Status s) {
                   std::lock_guard<std::mutex> lock(mu);
                   status = s;
                   done = true;
                   cv.notify_one();
                 });
  std::unique_lock<std::mutex> lock(mu);
  cv.wait(lock, [&] { return done; });
  if (!status.ok()) return false;
  std::vector<grpc::Slice> slices;
  if (!response.Dump(&slices).ok()) return false;
  std::string bytes;
  for (const grpc::Slice& slice : slices) {
    bytes.append(reinterpret_cast<const char*>(slice.begin()), slice.size());
  }
  return bytes == std::string("\x08\x01", 2);
}

ChildProcess::~ChildProcess() {
  if (pid_ > 0 && running()) Kill(SIGKILL);
}

bool ChildProcess::Start(const std::vector<std::string>& argv, const std::string& log_path) {
  log_path_ = log_path;
  exit_status_ = -1;
  const pid_t pid = fork();
  if (pid < 0) return false;
  if (pid == 0) {
    const int fd = open(log_path.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
    if (fd >= 0) {
      dup2(fd, STDOUT_FILENO);
      dup2(fd, STDERR_FILENO);
      close(fd);
    }
    std::vector<char*> args;
    for (const std::string& arg : argv) args.push_back(const_cast<char*>(arg.c_str()));
    args.push_back(nullptr);
    execv(args[0], args.data());
    _exit(127);
  }
  pid_ = pid;
  return true;
}

bool ChildProcess::running() {
  if (pid_ <= 0 || exit_status_ >= 0) return false;
  int status = 0;
  const pid_t r = waitpid(pid_, &status, WNOHANG);
  if (r == pid_) {
    exit_status_ = DecodeStatus(status);
    return false;
  }
  return r == 0;
}

int ChildProcess::Kill(int signal, std::chrono::milliseconds timeout) {
  if (pid_ <= 0) return -1;
  if (!running()) return exit_status_;
  ::kill(pid_, signal);
  const auto deadline = std::chrono::steady_clock::now() + Scaled(timeout);
  while (std::chrono::steady_clock::now() < deadline) {
    if (!running()) return exit_status_;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return -1;
}

std::string ChildProcess::Log() const {
  std::ifstream in(log_path_);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

bool ServerProcess::Start(const std::vector<std::string>& extra) {
  extra_ = extra;
  if (port_ == 0) port_ = FreePort();
  return Restart();
}

bool ServerProcess::Restart() {
  std::vector<std::string> argv = {BinPath("pf-server"),
                                   "--listen",
                                   "127.0.0.1:" + std::to_string(port_),
                                   "--store",
                                   store_.empty() ? "sqlite:" + dir_ + "/jobs.db" : store_,
                                   "--blobs",
                                   blobs_.empty() ? dir_ + "/blobs" : blobs_};
  argv.insert(argv.end(), extra_.begin(), extra_.end());
  ++starts_;
  if (!process_.Start(argv, dir_ + "/" + name_ + ".log")) return false;
  return WaitFor([&] { return process_.running() && Serving(address(), health_channel_); },
                 std::chrono::seconds(20));
}

std::string ServerProcess::address() const { return "127.0.0.1:" + std::to_string(port_); }

bool WorkerProcess::Start(const std::vector<std::string>& extra) {
  std::vector<std::string> argv = {BinPath("pf-worker"), "--server", server_, "--id", id_,
                                   "--work-dir",         work_dir()};
  argv.insert(argv.end(), extra.begin(), extra.end());
  ++starts_;
  return process_.Start(argv, dir_ + "/worker-" + id_ + ".log");
}

bool WaitFor(const std::function<bool()>& done, std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + Scaled(timeout);
  while (std::chrono::steady_clock::now() < deadline) {
    if (done()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  return done();
}

int CountOf(const std::string& text, const std::string& needle) {
  int count = 0;
  for (size_t at = text.find(needle); at != std::string::npos;
       at = text.find(needle, at + needle.size())) {
    ++count;
  }
  return count;
}

}  // namespace pf::testing
