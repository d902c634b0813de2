// Converting between grpc::Status and absl::Status (same code numbers), and
// building the channel every client uses.
#ifndef POINTFORWARD_RPC_GRPC_STATUS_H_
#define POINTFORWARD_RPC_GRPC_STATUS_H_

#include <memory>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "grpcpp/channel.h"
#include "grpcpp/support/status.h"

namespace pf {

absl::Status FromGrpc(const grpc::Status& status);
// Like FromGrpc, but UNAVAILABLE reads "server ADDRESS unreachable: ...", so
// a user sees which server could not be reached.
absl::Status FromGrpc(const grpc::Status& status, const std::string& server_address);
grpc::Status ToGrpc(const absl::Status& status);

// How a client reaches pf-server: TLS or plaintext, and the bearer token
// it sends (docs/SERVICE.md, "Authentication and TLS").
struct ChannelOptions {
  bool tls = false;
  std::string tls_ca_pem;    // Roots the server's certificate must chain to; empty: system roots.
  std::string tls_cert_pem;  // Client certificate chain for mutual TLS (with tls_key_pem).
  std::string tls_key_pem;
  std::string token;  // Sent as "authorization: Bearer <token>" on every call; empty: none.
};

// A channel to "HOST:PORT" in plaintext without a token. Messages up to 64 MiB.
std::shared_ptr<grpc::Channel> MakeChannel(const std::string& address);
// A channel as `options` say. The token travels in metadata added by a
// client interceptor to every call, on plaintext and TLS channels alike
// (gRPC refuses call credentials on a plaintext channel).
std::shared_ptr<grpc::Channel> MakeChannel(const std::string& address,
                                           const ChannelOptions& options);

// The client flags of pf and pf-worker, as given (paths; empty when absent).
struct ChannelFlags {
  std::string tls_ca;      // --tls-ca PEM, else $PF_TLS_CA.
  std::string tls_cert;    // --tls-cert PEM, else $PF_TLS_CERT.
  std::string tls_key;     // --tls-key PEM, else $PF_TLS_KEY.
  std::string token_file;  // --token-file PATH; else the first of `token_env` set.
};

// Reads the files `flags` name into ChannelOptions: TLS when any of
// tls_ca/tls_cert/tls_key is given (cert and key together); the token from
// token_file (surrounding whitespace dropped), else from the first
// environment variable in `token_env` that is set. INVALID_ARGUMENT naming
// the flag when a file cannot be read or is empty.
absl::StatusOr<ChannelOptions> LoadChannelOptions(ChannelFlags flags,
                                                  const std::vector<std::string>& token_env);

}  // namespace pf

#endif  // POINTFORWARD_RPC_GRPC_STATUS_H_
