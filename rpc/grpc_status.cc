// absl::Status <-> grpc::Status (both use the canonical code numbers) and the
// client channel.
#include "rpc/grpc_status.h"

#include <cstdlib>
#include <fstream>
#include <memory>
#include <sstream>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "common/status_macros.h"
#include "grpcpp/create_channel.h"
#include "grpcpp/security/credentials.h"
#include "grpcpp/support/channel_arguments.h"
#include "grpcpp/support/client_interceptor.h"

namespace pf {
namespace {

constexpr int kMaxMessageBytes = 64 << 20;

// Adds "authorization: Bearer <token>" to the initial metadata of every
// call of the channel it is installed on.
class BearerTokenInterceptor : public grpc::experimental::Interceptor {
 public:
  explicit BearerTokenInterceptor(const std::string* header) : header_(header) {}

  void Intercept(grpc::experimental::InterceptorBatchMethods* methods) override {
    if (methods->QueryInterceptionHookPoint(
            grpc::experimental::InterceptionHookPoints::PRE_SEND_INITIAL_METADATA)) {
      methods->GetSendInitialMetadata()->emplace("authorization", *header_);
    }
    methods->Proceed();
  }

 private:
  const std::string* header_;  // Owned by the factory, which the channel keeps.
};

class BearerTokenInterceptorFactory : public grpc::experimental::ClientInterceptorFactoryInterface {
 public:
  explicit BearerTokenInterceptorFactory(const std::string& token)
      : header_(absl::StrCat("Bearer ", token)) {}

  grpc::experimental::Interceptor* CreateClientInterceptor(
      grpc::experimental::ClientRpcInfo*) override {
    return new BearerTokenInterceptor(&header_);
  }

 private:
  const std::string header_;
};

// The content of the file `path` that --`flag` names, whitespace-trimmed
// when `trim`; INVALID_ARGUMENT naming the flag when unreadable or empty.
absl::StatusOr<std::string> ReadFlagFile(const std::string& path, const std::string& flag,
                                         bool trim) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return absl::InvalidArgumentError(absl::StrCat("--", flag, ": cannot read ", path));
  std::stringstream text;
  text << in.rdbuf();
  std::string content = text.str();
  if (trim) content = std::string(absl::StripAsciiWhitespace(content));
  if (content.empty()) {
    return absl::InvalidArgumentError(absl::StrCat("--", flag, ": ", path, " is empty"));
  }
  return content;
}

std::string FromEnvironment(const char* name) {
  const char* value = std::getenv(name);
  return value == nullptr ? "" : value;
}

}  // namespace

absl::Status FromGrpc(const grpc::Status& status) {
  if (status.ok()) return absl::OkStatus();
  return absl::Status(static_cast<absl::StatusCode>(status.error_code()), status.error_message());
}

absl::Status FromGrpc(const grpc::Status& status, const std::string& server_address) {
  if (status.error_code() != grpc::StatusCode::UNAVAILABLE) return FromGrpc(status);
  return absl::UnavailableError(absl::StrCat("server ",
                                             server_address.empty() ? "" : server_address + " ",
                                             "unreachable: ", status.error_message()));
}

grpc::Status ToGrpc(const absl::Status& status) {
  if (status.ok()) return grpc::Status::OK;
  return grpc::Status(static_cast<grpc::StatusCode>(status.code()), std::string(status.message()));
}

std::shared_ptr<grpc::Channel> MakeChannel(const std::string& address) {
  return MakeChannel(address, ChannelOptions());
}

std::shared_ptr<grpc::Channel> MakeChannel(const std::string& address,
                                           const ChannelOptions& options) {
  grpc::ChannelArguments args;
  args.SetMaxReceiveMessageSize(kMaxMessageBytes);
  args.SetMaxSendMessageSize(kMaxMessageBytes);
  std::shared_ptr<grpc::ChannelCredentials> credentials = grpc::InsecureChannelCredentials();
  if (options.tls) {
    grpc::SslCredentialsOptions ssl;
    ssl.pem_root_certs = options.tls_ca_pem;
    ssl.pem_cert_chain = options.tls_cert_pem;
    ssl.pem_private_key = options.tls_key_pem;
    credentials = grpc::SslCredentials(ssl);
  }
  std::vector<std::unique_ptr<grpc::experimental::ClientInterceptorFactoryInterface>> interceptors;
  if (!options.token.empty()) {
    interceptors.push_back(std::make_unique<BearerTokenInterceptorFactory>(options.token));
  }
  return grpc::experimental::CreateCustomChannelWithInterceptors(address, credentials, args,
                                                                 std::move(interceptors));
}

absl::StatusOr<ChannelOptions> LoadChannelOptions(ChannelFlags flags,
                                                  const std::vector<std::string>& token_env) {
  if (flags.tls_ca.empty()) flags.tls_ca = FromEnvironment("PF_TLS_CA");
  if (flags.tls_cert.empty()) flags.tls_cert = FromEnvironment("PF_TLS_CERT");
  if (flags.tls_key.empty()) flags.tls_key = FromEnvironment("PF_TLS_KEY");
  if (flags.tls_cert.empty() != flags.tls_key.empty()) {
    return absl::InvalidArgumentError(
        "--tls-cert and --tls-key: give both (a client certificate and its key) or neither");
  }
  ChannelOptions options;
  options.tls = !flags.tls_ca.empty() || !flags.tls_cert.empty();
  if (!flags.tls_ca.empty()) {
    ASSIGN_OR_RETURN(options.tls_ca_pem, ReadFlagFile(flags.tls_ca, "tls-ca", false));
  }
  if (!flags.tls_cert.empty()) {
    ASSIGN_OR_RETURN(options.tls_cert_pem, ReadFlagFile(flags.tls_cert, "tls-cert", false));
    ASSIGN_OR_RETURN(options.tls_key_pem, ReadFlagFile(flags.tls_key, "tls-key", false));
  }
  if (!flags.token_file.empty()) {
    ASSIGN_OR_RETURN(options.token, ReadFlagFile(flags.token_file, "token-file", true));
  } else {
    for (const std::string& name : token_env) {
      options.token = std::string(absl::StripAsciiWhitespace(FromEnvironment(name.c_str())));
      if (!options.token.empty()) break;
    }
  }
  for (char c : options.token) {
    if (c <= ' ' || c == 0x7f) {
      return absl::InvalidArgumentError(
          "token: holds whitespace or control characters; it cannot travel in a header");
    }
  }
  return options;
}

}  // namespace pf
