// Authenticator: see auth.h.
#include "server/auth.h"

#include <sys/stat.h>

#include <cctype>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "common/file_util.h"
#include "common/hash.h"
#include "spdlog/spdlog.h"

namespace pf {
namespace {

constexpr size_t kMinTokenLength = 16;
constexpr char kLineFormat[] = "<sha256-hex> <owner> [admin|worker]";

bool IsLowerHex(std::string_view text) {
  for (char c : text) {
    if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'))) return false;
  }
  return true;
}

// Compares two strings of equal length in time independent of where they
// differ (a token's hash must not leak through the lookup's timing).
bool ConstantTimeEquals(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  unsigned char difference = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    difference |= static_cast<unsigned char>(a[i] ^ b[i]);
  }
  return difference == 0;
}

}  // namespace

const char* RoleName(Role role) {
  switch (role) {
    case Role::kUser:
      return "user";
    case Role::kWorker:
      return "worker";
    case Role::kAdmin:
      return "admin";
  }
  return "unknown";
}

absl::StatusOr<std::vector<TokenEntry>> ParseTokenFile(const std::string& text,
                                                       const std::string& path) {
  std::vector<TokenEntry> entries;
  int line_number = 0;
  for (absl::string_view raw : absl::StrSplit(text, '\n')) {
    ++line_number;
    const absl::string_view line = absl::StripAsciiWhitespace(raw);
    if (line.empty() || line[0] == '#') continue;
    const std::vector<absl::string_view> words =
        absl::StrSplit(line, absl::ByAnyChar(" \t"), absl::SkipEmpty());
    const auto bad = [&](const std::string& why) {
      return absl::InvalidArgumentError(
          absl::StrCat(path, ":", line_number, ": ", why, " (expected '", kLineFormat, "')"));
    };
    if (words.size() < 2 || words.size() > 3) {
      return bad(absl::StrCat(words.size(), " words"));
    }
    TokenEntry entry;
    entry.sha256_hex = std::string(words[0]);
    if (entry.sha256_hex.size() != 64 || !IsLowerHex(entry.sha256_hex)) {
      return bad(absl::StrCat("'", words[0],
                              "' is not a SHA-256 in 64 lowercase hex digits (pf-server "
                              "hash-token prints one)"));
    }
    entry.owner = std::string(words[1]);
    if (words.size() == 3) {
      if (words[2] == "admin") {
        entry.role = Role::kAdmin;
      } else if (words[2] == "worker") {
        entry.role = Role::kWorker;
      } else {
        return bad(absl::StrCat("unknown role '", words[2], "'"));
      }
    }
    for (const TokenEntry& earlier : entries) {
      if (earlier.sha256_hex == entry.sha256_hex) return bad("the same token hash appears twice");
    }
    entries.push_back(std::move(entry));
  }
  return entries;
}

absl::StatusOr<std::string> HashToken(std::string_view token) {
  if (token.size() < kMinTokenLength) {
    return absl::InvalidArgumentError(absl::StrCat("token: ", token.size(),
                                                   " characters; use at least ", kMinTokenLength,
                                                   " (e.g. openssl rand -hex 32)"));
  }
  for (char c : token) {
    if (c <= ' ' || c == 0x7f) {
      return absl::InvalidArgumentError(
          "token: holds whitespace or control characters; it must fit in one header word");
    }
  }
  return Sha256Hex(token);
}

absl::StatusOr<std::string> BearerToken(std::string_view authorization) {
  if (authorization.empty()) return absl::UnauthenticatedError("missing bearer token");
  // Debian's abseil has its own string_view: convert once.
  const absl::string_view header(authorization.data(), authorization.size());
  constexpr absl::string_view kScheme = "bearer ";
  if (header.size() <= kScheme.size() ||
      !absl::EqualsIgnoreCase(header.substr(0, kScheme.size()), kScheme)) {
    return absl::UnauthenticatedError(
        "missing bearer token: the authorization metadata is not 'Bearer <token>'");
  }
  return std::string(absl::StripAsciiWhitespace(header.substr(kScheme.size())));
}

absl::StatusOr<std::unique_ptr<Authenticator>> Authenticator::FromFile(const std::string& path) {
  if (path.empty()) return absl::InvalidArgumentError("--auth-token-file: empty path");
  std::unique_ptr<Authenticator> auth(new Authenticator(path));
  std::lock_guard<std::mutex> lock(auth->mu_);
  if (absl::Status loaded = auth->LoadIfChanged(); !loaded.ok()) {
    return absl::InvalidArgumentError(
        absl::StrCat("--auth-token-file: ", std::string(loaded.message())));
  }
  auth->last_check_ = std::chrono::steady_clock::now();
  return auth;
}

absl::Status Authenticator::LoadIfChanged() {
  struct stat info {};
  if (stat(path_.c_str(), &info) != 0) {
    return absl::NotFoundError(absl::StrCat(path_, ": cannot stat the token file"));
  }
  const FileVersion version{int64_t{info.st_mtim.tv_sec} * 1000000000 + info.st_mtim.tv_nsec,
                            static_cast<int64_t>(info.st_size), info.st_ino};
  if (version == version_) return absl::OkStatus();
  absl::StatusOr<std::string> text = ReadFileToString(path_);
  if (!text.ok()) return text.status();
  absl::StatusOr<std::vector<TokenEntry>> tokens = ParseTokenFile(*text, path_);
  if (!tokens.ok()) return tokens.status();
  const bool first = version_.size < 0;
  tokens_ = *std::move(tokens);
  version_ = version;
  spdlog::info("{} token file {}: {} token(s)", first ? "read" : "reloaded", path_, tokens_.size());
  return absl::OkStatus();
}

void Authenticator::MaybeReload() {
  const auto now = std::chrono::steady_clock::now();
  if (now - last_check_ < kReloadInterval) return;
  last_check_ = now;
  if (absl::Status loaded = LoadIfChanged(); !loaded.ok()) {
    spdlog::error("token file not reloaded, keeping the {} token(s) read before: {}",
                  tokens_.size(), std::string(loaded.message()));
  }
}

absl::StatusOr<Caller> Authenticator::Authenticate(const grpc::ServerContext& context) {
  if (!enabled()) return Caller{"", Role::kAdmin};
  const auto& metadata = context.client_metadata();
  const auto found = metadata.find("authorization");
  if (found == metadata.end()) return absl::UnauthenticatedError("missing bearer token");
  return AuthenticateHeader(std::string_view(found->second.data(), found->second.size()));
}

absl::StatusOr<Caller> Authenticator::AuthenticateHeader(std::string_view authorization) {
  if (!enabled()) return Caller{"", Role::kAdmin};
  absl::StatusOr<std::string> token = BearerToken(authorization);
  if (!token.ok()) return token.status();
  const std::string hash = Sha256Hex(*token);
  std::lock_guard<std::mutex> lock(mu_);
  MaybeReload();
  // Every entry is compared, in constant time each, so the time taken does
  // not tell how much of a hash matched nor where in the file it is.
  const TokenEntry* match = nullptr;
  for (const TokenEntry& entry : tokens_) {
    if (ConstantTimeEquals(entry.sha256_hex, hash)) match = &entry;
  }
  if (match == nullptr) return absl::UnauthenticatedError("unknown token");
  return Caller{match->owner, match->role};
}

}  // namespace pf
