// PostgresServer: initdb + pg_ctl run as `postgres` through runuser, a
// port found by binding port 0, databases created over libpq.
#include "tests/postgres_server.h"

#include <libpq-fe.h>
#include <netinet/in.h>
#include <pwd.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <mutex>
#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "common/status_macros.h"
#include "tests/test_util.h"

namespace pf::testing {
namespace {

namespace fs = std::filesystem;

constexpr char kUser[] = "postgres";
constexpr char kRunuser[] = "/usr/sbin/runuser";

std::string BinDir() {
  const char* dir = std::getenv("PF_POSTGRES_BIN_DIR");
  return dir != nullptr && *dir != '\0' ? dir : "/usr/lib/postgresql/15/bin";
}

// Returns a loopback TCP port nobody listens on right now.
absl::StatusOr<int> FreeLoopbackPort() {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) return absl::InternalError("socket() failed");
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  address.sin_port = 0;
  socklen_t length = sizeof(address);
  const bool ok = ::bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof(address)) == 0 &&
                  ::getsockname(fd, reinterpret_cast<sockaddr*>(&address), &length) == 0;
  ::close(fd);
  if (!ok) return absl::InternalError("cannot bind a loopback port");
  return static_cast<int>(ntohs(address.sin_port));
}

// Runs `argv` as the postgres user; the error names the step and shows
// its output.
absl::Status RunAsPostgres(const std::string& step, std::vector<std::string> argv) {
  argv.insert(argv.begin(), {kRunuser, "-u", kUser, "--"});
  const CommandResult result = RunCommand(argv);
  if (result.exit_code == 0) return absl::OkStatus();
  return absl::InternalError(absl::StrCat(
      "test PostgreSQL: ", step, " exited with ", result.exit_code, ": ",
      absl::StripAsciiWhitespace(result.err), " ", absl::StripAsciiWhitespace(result.out)));
}

// Returns the tail of the server log, for errors.
std::string LogTail(const std::string& root) {
  std::string log;
  if (FILE* file = std::fopen((root + "/server.log").c_str(), "r")) {
    char buffer[4096];
    size_t got;
    while ((got = std::fread(buffer, 1, sizeof(buffer), file)) > 0) log.append(buffer, got);
    std::fclose(file);
  }
  return log.size() > 2000 ? log.substr(log.size() - 2000) : log;
}

// Runs initdb for a data directory at `data` (whose parent `postgres`
// owns): superuser `postgres`, trust authentication, UTF-8, C collation,
// 1 MB WAL segments (instead of 16: less to copy per test process).
absl::Status InitDb(const std::string& data) {
  return RunAsPostgres("initdb", {BinDir() + "/initdb", "-D", data, "-U", kUser, "-A", "trust",
                                  "-E", "UTF8", "--locale=C", "--wal-segsize=1", "--no-sync"});
}

// Creates a directory like mkdtemp, owned by `postgres`; returns its path.
absl::StatusOr<std::string> MakePostgresDir(const std::string& pattern_prefix) {
  std::string dir = pattern_prefix + "XXXXXX";
  if (::mkdtemp(dir.data()) == nullptr) {
    return absl::InternalError(absl::StrCat("cannot create a directory ", dir));
  }
  const passwd* user = ::getpwnam(kUser);
  if (user == nullptr || ::chown(dir.c_str(), user->pw_uid, user->pw_gid) != 0) {
    fs::remove_all(dir);
    return absl::InternalError(absl::StrCat("cannot chown ", dir, " to ", kUser));
  }
  return dir;
}

// Fills `data` with a fresh cluster. initdb takes seconds and ctest runs
// each test in its own process, so its output is kept once per PostgreSQL
// build as a template under `base` (made in a scratch directory, then
// renamed into place, so a template that exists is complete even when
// several processes race to make it) and copied. PF_POSTGRES_NO_TEMPLATE
// set: initdb every time.
absl::Status MakeDataDirectory(const std::string& base, const std::string& data) {
  if (std::getenv("PF_POSTGRES_NO_TEMPLATE") != nullptr) return InitDb(data);
  struct stat initdb {};
  if (::stat((BinDir() + "/initdb").c_str(), &initdb) != 0) {
    return absl::NotFoundError(absl::StrCat(BinDir(), "/initdb not found"));
  }
  // A new PostgreSQL build (size or time of initdb) or new InitDb options
  // (kTemplateVersion) get a new template.
  constexpr int kTemplateVersion = 2;
  const std::string template_dir =
      absl::StrCat(base, "/pf_postgres_template_v", kTemplateVersion, "_", ::geteuid(), "_",
                   initdb.st_size, "_", initdb.st_mtime);
  std::error_code ec;
  if (!fs::exists(template_dir, ec)) {
    ASSIGN_OR_RETURN(const std::string scratch,
                     MakePostgresDir(base + "/pf_postgres_template_build_"));
    absl::Status status = InitDb(scratch + "/data");
    // Losing the race to another process is fine: its template is as good.
    if (status.ok()) ::rename((scratch + "/data").c_str(), template_dir.c_str());
    fs::remove_all(scratch, ec);
    RETURN_IF_ERROR(status);
  }
  const CommandResult copy = RunCommand({"/bin/cp", "-a", template_dir, data});
  if (copy.exit_code != 0) {
    return absl::InternalError(
        absl::StrCat("copying ", template_dir, " to ", data, ": ", copy.err));
  }
  return absl::OkStatus();
}

}  // namespace

std::optional<std::string> PostgresServer::WhyUnavailable() {
  if (::geteuid() != 0) {
    return std::string(
        "PostgreSQL tests need root (they run a throwaway server as the 'postgres' user); "
        "skipped");
  }
  if (::getpwnam(kUser) == nullptr) {
    return std::string(
        "no 'postgres' user: install Debian's postgresql package "
        "(scripts/install-deps.sh); PostgreSQL tests skipped");
  }
  for (const char* binary : {"initdb", "pg_ctl", "postgres"}) {
    if (::access((BinDir() + "/" + binary).c_str(), X_OK) != 0) {
      return absl::StrCat("PostgreSQL binary ", BinDir(), "/", binary,
                          " not found: install Debian's postgresql package "
                          "(scripts/install-deps.sh) or set PF_POSTGRES_BIN_DIR; "
                          "PostgreSQL tests skipped");
    }
  }
  if (::access(kRunuser, X_OK) != 0) return std::string("no /usr/sbin/runuser; skipped");
  return std::nullopt;
}

absl::StatusOr<std::unique_ptr<PostgresServer>> PostgresServer::Start() {
  if (std::optional<std::string> why = WhyUnavailable()) {
    return absl::FailedPreconditionError(*why);
  }
  const std::string base = std::getenv("TMPDIR") != nullptr ? std::getenv("TMPDIR") : "/tmp";
  ASSIGN_OR_RETURN(const std::string root, MakePostgresDir(base + "/pf_postgres_"));
  // From here on the object owns the directory: its destructor removes it.
  std::unique_ptr<PostgresServer> server(new PostgresServer(root));
  RETURN_IF_ERROR(MakeDataDirectory(base, root + "/data"));
  // Another process may take the port between the probe and the start:
  // try a few.
  absl::Status status;
  for (int attempt = 0; attempt < 5; ++attempt) {
    ASSIGN_OR_RETURN(server->port_, FreeLoopbackPort());
    status = server->StartProcess();
    if (status.ok()) return server;
  }
  return status;
}

absl::StatusOr<PostgresServer*> PostgresServer::Shared() {
  static std::mutex mutex;
  static absl::StatusOr<std::unique_ptr<PostgresServer>>* shared = nullptr;
  std::lock_guard<std::mutex> lock(mutex);
  if (shared == nullptr) {
    shared = new absl::StatusOr<std::unique_ptr<PostgresServer>>(Start());
    // Stopped when the test binary exits normally.
    std::atexit([] {
      if (shared->ok()) shared->value().reset();
    });
  }
  if (!shared->ok()) return shared->status();
  return shared->value().get();
}

absl::Status PostgresServer::StartProcess() {
  // Durability off (a test server), connections enough for the
  // concurrency tests, the socket in our own directory.
  const std::string options =
      absl::StrCat("-c listen_addresses=127.0.0.1 -p ", port_, " -k ", root_,
                   " -c fsync=off -c synchronous_commit=off -c full_page_writes=off"
                   " -c max_connections=200");
  absl::Status status = RunAsPostgres(
      "pg_ctl start", {BinDir() + "/pg_ctl", "-D", root_ + "/data", "-l", root_ + "/server.log",
                       "-o", options, "-w", "-t", "60", "start"});
  if (!status.ok()) return StatusWithLog(status);
  running_ = true;
  return absl::OkStatus();
}

absl::Status PostgresServer::StatusWithLog(const absl::Status& status) const {
  return absl::Status(status.code(),
                      absl::StrCat(status.message(), "\nserver log:\n", LogTail(root_)));
}

absl::Status PostgresServer::Stop() {
  if (!running_) return absl::OkStatus();
  running_ = false;
  return RunAsPostgres("pg_ctl stop", {BinDir() + "/pg_ctl", "-D", root_ + "/data", "-m", "fast",
                                       "-w", "-t", "60", "stop"});
}

absl::Status PostgresServer::Restart() {
  if (absl::Status status = Stop(); !status.ok()) return status;
  return StartProcess();
}

PostgresServer::~PostgresServer() {
  Stop().IgnoreError();
  std::error_code ignored;
  fs::remove_all(root_, ignored);
}

std::string PostgresServer::Url(const std::string& name) const {
  return absl::StrCat("postgresql://", kUser, "@127.0.0.1:", port_, "/", name);
}

absl::StatusOr<std::string> PostgresServer::CreateDatabase(const std::string& name) {
  if (name.empty() || !std::all_of(name.begin(), name.end(),
                                   [](char c) { return absl::ascii_isalnum(c) || c == '_'; })) {
    return absl::InvalidArgumentError(
        absl::StrCat("database name '", name, "': only letters, digits and '_'"));
  }
  PGconn* conn = PQconnectdb(Url("postgres").c_str());
  absl::Status status;
  if (PQstatus(conn) != CONNECTION_OK) {
    status = absl::UnavailableError(
        absl::StrCat("test PostgreSQL on port ", port_, ": ", PQerrorMessage(conn)));
  } else {
    PGresult* result = PQexec(conn, absl::StrCat("CREATE DATABASE \"", name, "\"").c_str());
    if (PQresultStatus(result) != PGRES_COMMAND_OK) {
      status = absl::InternalError(absl::StrCat("test PostgreSQL: CREATE DATABASE ", name, ": ",
                                                PQresultErrorMessage(result)));
    }
    PQclear(result);
  }
  PQfinish(conn);
  if (!status.ok()) return status;
  return Url(name);
}

absl::StatusOr<std::string> PostgresServer::CreateFreshDatabase() {
  return CreateDatabase(absl::StrCat("pf_test_", ++databases_created_));
}

}  // namespace pf::testing
