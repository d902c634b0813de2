// Dispatch of remote `pf` commands and the reporting of their errors.
#include "client/remote/remote_main.h"

#include <cstdio>
#include <cstdlib>
#include <exception>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "client/commands.h"
#include "client/remote/remote_commands.h"
#include "client/remote/remote_context.h"
#include "google/protobuf/util/json_util.h"
#include "rpc/grpc_status.h"

namespace pf {

absl::StatusOr<std::string> ToJson(const google::protobuf::Message& message) {
  google::protobuf::util::JsonPrintOptions options;
  options.add_whitespace = true;
  std::string json;
  try {
    const auto status = google::protobuf::util::MessageToJsonString(message, &json, options);
    if (!status.ok()) {
      return absl::InternalError(absl::StrCat("cannot print ", message.GetTypeName(),
                                              " as JSON: ", std::string(status.message())));
    }
  } catch (const std::exception& e) {
    return absl::InternalError(
        absl::StrCat("cannot print ", message.GetTypeName(), " as JSON: ", e.what()));
  }
  while (!json.empty() && json.back() == '\n') json.pop_back();
  return json;
}

bool IsRemoteCommand(const std::string& command) {
  return command == "scene" || command == "render" || command == "jobs";
}

namespace {

// Takes the connection flags (--tls-ca, --tls-cert, --tls-key, --token-file;
// "--flag value" or "--flag=value") off the front of `*args`.
absl::StatusOr<ChannelFlags> TakeConnectionFlags(std::vector<std::string>* args) {
  ChannelFlags flags;
  const std::pair<const char*, std::string*> kFlags[] = {{"--tls-ca", &flags.tls_ca},
                                                         {"--tls-cert", &flags.tls_cert},
                                                         {"--tls-key", &flags.tls_key},
                                                         {"--token-file", &flags.token_file}};
  size_t at = 0;
  while (at < args->size()) {
    const std::string& word = (*args)[at];
    bool matched = false;
    for (const auto& [name, value] : kFlags) {
      if (word == name) {
        if (at + 1 >= args->size() || (*args)[at + 1].empty()) {
          return absl::InvalidArgumentError(absl::StrCat(name, ": needs a path"));
        }
        *value = (*args)[at + 1];
        at += 2;
        matched = true;
      } else if (absl::StartsWith(word, absl::StrCat(name, "="))) {
        *value = word.substr(std::string(name).size() + 1);
        at += 1;
        matched = true;
      }
      if (matched) break;
    }
    if (!matched) break;
  }
  args->erase(args->begin(), args->begin() + at);
  return flags;
}

}  // namespace

int RunRemote(const std::string& address, const std::vector<std::string>& all_args) {
  std::vector<std::string> args = all_args;
  absl::StatusOr<ChannelFlags> flags = TakeConnectionFlags(&args);
  absl::StatusOr<ChannelOptions> channel =
      flags.ok() ? LoadChannelOptions(*flags, {"PF_TOKEN"}) : flags.status();
  if (!channel.ok()) {
    std::fprintf(stderr, "pf: %s\n", std::string(channel.status().message()).c_str());
    return kExitBadInput;
  }
  if (args.empty() || !IsRemoteCommand(args[0])) {
    std::fprintf(stderr,
                 "pf: %s is not a remote command: with --server, use scene, render or "
                 "jobs (see pf help)\n",
                 args.empty() ? "nothing" : absl::StrCat("'", args[0], "'").c_str());
    return kExitBadInput;
  }
  const std::string& group = args[0];
  const std::vector<std::string> rest(args.begin() + 1, args.end());
  // "scene create", "jobs wait", "render": the command named in messages.
  const std::string label = group == "render" || rest.empty() ? group : group + " " + rest[0];

  RemoteContext ctx(address, stdout, *std::move(channel));
  absl::StatusOr<int> result;
  try {
    if (group == "scene") {
      result = RunRemoteScene(ctx, rest);
    } else if (group == "render") {
      result = RunRemoteRender(ctx, rest);
    } else {
      result = RunRemoteJobs(ctx, rest);
    }
  } catch (const std::exception& e) {
    result = absl::InternalError(absl::StrCat("unexpected error: ", e.what()));
  }
  if (result.ok()) return *result;
  if (result.status().code() == absl::StatusCode::kUnauthenticated) {
    // Say where a token comes from.
    return ReportError(label, absl::UnauthenticatedError(absl::StrCat(
                                  result.status().message(),
                                  "; give the server a token: set PF_TOKEN, or put it in a file "
                                  "and pass --token-file FILE before the command")));
  }
  if (result.status().code() == absl::StatusCode::kUnavailable) {
    std::fprintf(stderr, "pf: server %s unreachable: %s\n", address.c_str(),
                 std::string(result.status().message()).c_str());
    return kExitUnreachable;
  }
  return ReportError(label, result.status());
}

std::optional<int> RunRemoteIfAsked(const std::vector<std::string>& words) {
  if (!words.empty() && (words[0] == "--server" || absl::StartsWith(words[0], "--server="))) {
    const bool joined = words[0] != "--server";
    const std::string address = joined ? words[0].substr(9) : (words.size() > 1 ? words[1] : "");
    if (address.empty()) {
      std::fputs("pf: --server needs an address (HOST:PORT)\n", stderr);
      return kExitBadInput;
    }
    const size_t first = joined ? 1 : 2;
    return RunRemote(address, std::vector<std::string>(words.begin() + first, words.end()));
  }
  const char* server = std::getenv("PF_SERVER");
  // PF_SERVER: remote commands, with or without connection flags first.
  const bool connection_flag = !words.empty() && (absl::StartsWith(words[0], "--tls-") ||
                                                  absl::StartsWith(words[0], "--token-file"));
  if (server != nullptr && server[0] != '\0' && !words.empty() &&
      (IsRemoteCommand(words[0]) || connection_flag)) {
    return RunRemote(server, words);
  }
  return std::nullopt;
}

}  // namespace pf
