// Converting between grpc::Status and absl::Status (same code numbers), and
// building the channel every client uses.
#ifndef POINTFORWARD_RPC_GRPC_STATUS_H_
#define POINTFORWARD_RPC_GRPC_STATUS_H_

#include <memory>
#include <string>

#include "absl/status/status.h"
#include "grpcpp/channel.h"
#include "grpcpp/support/status.h"

namespace pf {

absl::Status FromGrpc(const grpc::Status& status);
// Like FromGrpc, but UNAVAILABLE reads "server ADDRESS unreachable: ...", so
// a user sees which server could not be reached.
absl::Status FromGrpc(const grpc::Status& status, const std::string& server_address);
grpc::Status ToGrpc(const absl::Status& status);

// A channel to "HOST:PORT" (insecure for now). Messages up to 64 MiB.
std::shared_ptr<grpc::Channel> MakeChannel(const std::string& address);

}  // namespace pf

#endif  // POINTFORWARD_RPC_GRPC_STATUS_H_
