// Bearer-token authentication of pf-server's callers.
//
// Tokens live in a token file, never in clear: one line per token,
//
//   # comment lines and blank lines are ignored
//   <sha256-hex-of-token> <owner> [admin|worker]
//
// The hash is the SHA-256 of the token's bytes as the client sends them
// (`printf %s "$TOKEN" | pf-server hash-token` prints it). The owner names
// whose jobs and scenes the token sees; several tokens may share an owner.
// No role: an ordinary user. `worker`: may also call WorkerService (for
// pf-worker). `admin`: sees, cancels and may do everything.
//
// Clients send `authorization: Bearer <token>` metadata on every call. The
// file is read at start (an unreadable or malformed file stops the server)
// and re-read when it changes: on use, at most once per second, the file's
// modification time, size and inode are compared with the last read, so a
// token added or removed takes effect within a second without a restart. A
// reload that fails (the file half-written, a malformed line) keeps the
// previous tokens and logs the error.
//
// With no token file, authentication is off: every caller is the owner ""
// with the admin role, as before authentication existed.
//
//   ASSIGN_OR_RETURN(std::unique_ptr<Authenticator> auth, Authenticator::FromFile(path));
//   absl::StatusOr<Caller> caller = auth->Authenticate(*context);  // In a handler.
#ifndef POINTFORWARD_SERVER_AUTH_H_
#define POINTFORWARD_SERVER_AUTH_H_

#include <sys/types.h>

#include <chrono>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "grpcpp/server_context.h"

namespace pf {

enum class Role { kUser, kWorker, kAdmin };

// "user", "worker", "admin".
const char* RoleName(Role role);

// Who makes a call.
struct Caller {
  std::string owner;
  Role role = Role::kUser;

  bool admin() const { return role == Role::kAdmin; }
  // May call WorkerService.
  bool worker() const { return role == Role::kWorker || role == Role::kAdmin; }
};

// One line of a token file.
struct TokenEntry {
  std::string sha256_hex;  // 64 lowercase hex digits.
  std::string owner;
  Role role = Role::kUser;
};

// Parses a token file's text; errors name `path` and the line
// ("tokens.txt:3: expected '<sha256-hex> <owner> [admin|worker]', got ...").
absl::StatusOr<std::vector<TokenEntry>> ParseTokenFile(const std::string& text,
                                                       const std::string& path);

// The token file hash of `token`: the SHA-256 of its bytes in lowercase hex.
// INVALID_ARGUMENT when the token is shorter than 16 characters or holds
// whitespace or control characters (it could not travel in a header).
absl::StatusOr<std::string> HashToken(std::string_view token);

// The token of an `authorization` metadata value "Bearer <token>" (the
// scheme is case-insensitive); UNAUTHENTICATED otherwise.
absl::StatusOr<std::string> BearerToken(std::string_view authorization);

class Authenticator {
 public:
  // Authentication off: Authenticate() returns Caller{"", Role::kAdmin}.
  Authenticator() = default;
  Authenticator(const Authenticator&) = delete;
  Authenticator& operator=(const Authenticator&) = delete;

  // Reads the token file at `path`; INVALID_ARGUMENT (naming the file and
  // line) when it cannot be read or parsed.
  static absl::StatusOr<std::unique_ptr<Authenticator>> FromFile(const std::string& path);

  bool enabled() const { return !path_.empty(); }
  const std::string& path() const { return path_; }

  // The caller of a call from its `authorization` metadata. UNAUTHENTICATED
  // "missing bearer token" when there is none, "unknown token" when its hash
  // is not in the file.
  absl::StatusOr<Caller> Authenticate(const grpc::ServerContext& context);
  // The same for the metadata value itself (empty: none sent).
  absl::StatusOr<Caller> AuthenticateHeader(std::string_view authorization);

  // How often, at most, the file is checked for changes.
  static constexpr std::chrono::seconds kReloadInterval{1};

 private:
  struct FileVersion {
    int64_t mtime_ns = 0;
    int64_t size = -1;
    ino_t inode = 0;
    bool operator==(const FileVersion&) const = default;
  };

  explicit Authenticator(std::string path) : path_(std::move(path)) {}
  // Reads the file into `tokens_` when it changed since the last read.
  // Called with `mu_` held.
  absl::Status LoadIfChanged();
  void MaybeReload();

  std::string path_;
  std::mutex mu_;
  std::vector<TokenEntry> tokens_;                      // Guarded by mu_.
  FileVersion version_;                                 // Guarded by mu_.
  std::chrono::steady_clock::time_point last_check_{};  // Guarded by mu_.
};

}  // namespace pf

#endif  // POINTFORWARD_SERVER_AUTH_H_
